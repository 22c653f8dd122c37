// A small blocking HTTP/1.1 client (Boost.Beast) for tests: one keep-alive connection to
// 127.0.0.1:port, reconnecting when the server closed it.
#pragma once

#include <map>
#include <memory>
#include <string>

namespace zoomwarp::testing {

struct HttpResponse {
  int status = 0;
  std::map<std::string, std::string> headers;  // lower-case names
  std::string body;
  std::string header(const std::string& name) const {
    auto it = headers.find(name);
    return it == headers.end() ? std::string() : it->second;
  }
};

class HttpClient {
 public:
  explicit HttpClient(int port);
  ~HttpClient();

  HttpResponse get(const std::string& target, const std::map<std::string, std::string>& headers = {});
  HttpResponse request(const std::string& method, const std::string& target, const std::string& body = "",
                       const std::map<std::string, std::string>& headers = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// A raw exchange on a fresh connection: sends `bytes` as they are and returns what came back
// until the server closed the connection (or `timeout_ms` passed). For malformed-request tests.
std::string raw_exchange(int port, const std::string& bytes, int timeout_ms = 5000);

}  // namespace zoomwarp::testing
