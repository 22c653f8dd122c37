// CORS (Fetch standard): reads are open to every origin, writes only to the configured ones.
//
//  - GET/HEAD answers, and preflights asking for them, say Access-Control-Allow-Origin: *.
//  - Writes (POST, PUT, PATCH, DELETE): a preflight from an origin of --cors-write-origins gets
//    that exact origin, the write methods and the headers a write sends (Authorization,
//    Content-Type, If-Match); the write's answer names the origin again. Any other origin gets no
//    allow headers, so the browser refuses to send the write (preflighted) or to show its answer.
//    These answers carry Vary: Origin, since they differ by origin.
//  - No Access-Control-Allow-Credentials: keys travel in the Authorization header, which a page
//    sets itself; that is not "credentials mode" in Fetch (cookies, HTTP authentication the browser
//    manages, TLS client certificates are), and the server uses none of those. So a page may send a
//    key with `fetch` (credentials: "omit" or "same-origin") and the server never needs to answer
//    credentialed requests — which, with `*`, it could not anyway.
//
// Threads: a CorsPolicy is immutable after construction; use it from any thread.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace zoomwarp::server {

using HeaderList = std::vector<std::pair<std::string, std::string>>;

class CorsPolicy {
 public:
  CorsPolicy() = default;  // no origin may write
  // `write_origins`: exact origins such as "https://curate.example.org" (scheme://host[:port]).
  explicit CorsPolicy(std::vector<std::string> write_origins) : write_origins_(std::move(write_origins)) {}

  // Parses --cors-write-origins: comma-separated origins; empty: none. Throws
  // std::invalid_argument for an entry that is not scheme://host[:port] (no path, no "*").
  static CorsPolicy parse(std::string_view list);

  static bool is_write(std::string_view method);

  // The headers of a preflight (OPTIONS) from `origin` for `requested_method`
  // (Access-Control-Request-Method).
  HeaderList preflight(std::string_view origin, std::string_view requested_method) const;

  // The CORS headers of the answer to a `method` request from `origin` (empty if none).
  HeaderList response(std::string_view method, std::string_view origin) const;

 private:
  bool may_write(std::string_view origin) const;

  std::vector<std::string> write_origins_;
};

}  // namespace zoomwarp::server
