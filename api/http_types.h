// The api layer's view of HTTP: plain structs, no Beast. The server fills a Request from the wire
// and writes a Response back, so routes can be tested and reused without sockets.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace zoomwarp::warp {
class StopToken;
}

namespace zoomwarp::api {

struct Request {
  std::string method;         // "GET", "HEAD", "POST", ...
  std::string path;           // raw (still percent-encoded) path, without the query
  std::string query;          // raw query string, without '?'
  std::string host;           // Host header: IIIF ids are absolute URLs
  std::string forwarded_proto;  // X-Forwarded-Proto, when behind a proxy
  std::string if_none_match;
  std::string if_match;       // edits: the image ETag (GET /v1/images/{id}) they were made against
  std::string accept;
  std::string authorization;   // Authorization header, e.g. "Bearer …" (never logged)
  std::string origin;          // Origin header (CORS)
  std::string client_address;  // the peer's IP address as the server saw it (no port)
  std::string body;           // small bodies (JSON)
  std::string body_file;      // uploads: a file the server streamed the body into
  // The request's deadline and cancel flag (warp/core/stop_token.h), owned by the server and alive
  // until the response is sent; null: no limit. Computations check it at step boundaries.
  const warp::StopToken* stop = nullptr;
};

struct Response {
  int status = 200;
  std::string content_type;
  std::shared_ptr<const std::string> body;
  std::vector<std::pair<std::string, std::string>> headers;  // besides Content-Type
  std::string route;  // a stable label for metrics and logs, e.g. "dzi_tile"
  std::string cache;  // "hit", "miss", "negative" (api/failure_cache.h) or "" where no cache is involved
  // Why the request failed on the server's side, for metrics: "deadline" or "cancelled" (its
  // StopToken ended its work), "internal_error" (a 500), "negative_cache" (a remembered failure,
  // api/failure_cache.h); "" otherwise, also for the client's own errors (4xx).
  std::string failure;
  std::string log_detail;  // what went wrong, for the server's log only: never sent to the client

  void set_header(std::string name, std::string value) {
    headers.emplace_back(std::move(name), std::move(value));
  }
};

}  // namespace zoomwarp::api
