// A blocking HTTP/1.1 GET client on one keep-alive connection, with a time limit on every step,
// for `zoomwarp replay` and `zoomwarp health`. One per thread. Beast stays inside http_client.cc.
#pragma once

#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>

namespace zoomwarp::server {

// Resolving, connecting, writing or reading failed or took over the time limit.
class HttpClientError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct HttpClientResponse {
  int status = 0;
  std::string body;
};

class HttpClient {
 public:
  // Nothing happens until the first get(): host is resolved and connected to then.
  HttpClient(std::string host, std::string port, std::chrono::milliseconds timeout);
  ~HttpClient();
  HttpClient(const HttpClient&) = delete;
  HttpClient& operator=(const HttpClient&) = delete;

  // GET `target` ("/v1/images?…"), connecting first when there is no open connection. Throws
  // HttpClientError and drops the connection on failure, so the next call reconnects.
  HttpClientResponse get(const std::string& target);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace zoomwarp::server
