#include "server/cors.h"

#include <algorithm>
#include <regex>
#include <stdexcept>

namespace zoomwarp::server {

namespace {
constexpr const char* kExposed = "ETag, Last-Modified, Location, Retry-After, Content-Length, WWW-Authenticate";
constexpr const char* kMaxAge = "86400";
}  // namespace

CorsPolicy CorsPolicy::parse(std::string_view list) {
  static const std::regex origin(R"(https?://[A-Za-z0-9.\-]+(:\d{1,5})?|https?://\[[0-9A-Fa-f:.]+\](:\d{1,5})?)");
  std::vector<std::string> origins;
  while (!list.empty()) {
    const std::size_t comma = list.find(',');
    std::string item(list.substr(0, comma));
    list = comma == std::string_view::npos ? std::string_view() : list.substr(comma + 1);
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (item.empty()) continue;
    if (!std::regex_match(item, origin))
      throw std::invalid_argument("--cors-write-origins: '" + item + "' is not an origin (scheme://host[:port])");
    origins.push_back(std::move(item));
  }
  return CorsPolicy(std::move(origins));
}

bool CorsPolicy::is_write(std::string_view m) { return m == "POST" || m == "PUT" || m == "PATCH" || m == "DELETE"; }

bool CorsPolicy::may_write(std::string_view origin) const {
  return !origin.empty() && std::find(write_origins_.begin(), write_origins_.end(), origin) != write_origins_.end();
}

HeaderList CorsPolicy::preflight(std::string_view origin, std::string_view requested_method) const {
  HeaderList h = {{"Vary", "Origin"}};
  if (!is_write(requested_method)) {
    h.insert(h.end(), {{"Access-Control-Allow-Origin", "*"},
                       {"Access-Control-Allow-Methods", "GET, HEAD"},
                       {"Access-Control-Allow-Headers", "Authorization, If-None-Match"},
                       {"Access-Control-Max-Age", kMaxAge}});
  } else if (may_write(origin)) {
    h.insert(h.end(), {{"Access-Control-Allow-Origin", std::string(origin)},
                       {"Access-Control-Allow-Methods", "POST, PUT, PATCH, DELETE"},
                       {"Access-Control-Allow-Headers", "Authorization, Content-Type, If-Match"},
                       {"Access-Control-Max-Age", kMaxAge}});
  }
  return h;
}

HeaderList CorsPolicy::response(std::string_view method, std::string_view origin) const {
  if (!is_write(method)) return {{"Access-Control-Allow-Origin", "*"}, {"Access-Control-Expose-Headers", kExposed}};
  if (!may_write(origin)) return {{"Vary", "Origin"}};
  return {{"Access-Control-Allow-Origin", std::string(origin)},
          {"Access-Control-Expose-Headers", kExposed},
          {"Vary", "Origin"}};
}

}  // namespace zoomwarp::server
