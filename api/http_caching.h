// HTTP caching for immutable image versions: strong ETags from the image version and the request,
// Last-Modified from the publish time, and If-None-Match matching (RFC 9110 §13.1.2).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace zoomwarp::api {

// FNV-1a, 64-bit: a hash stable across builds and machines (std::hash is neither). Feed data in
// pieces by passing the previous result as `h`.
inline constexpr std::uint64_t kFnvOffset = 1469598103934665603ULL;
std::uint64_t fnv1a64(std::string_view data, std::uint64_t h = kFnvOffset);

// 16 lower-case hex digits.
std::string hex64(std::uint64_t v);

// "\"<version>-<hash of key>\"": changes whenever the image is re-published or the request differs.
std::string make_etag(std::string_view version, std::string_view key);

// IMF-fixdate, e.g. "Sun, 06 Nov 1994 08:49:37 GMT".
std::string http_date(std::int64_t unix_ms);

// Whether an If-None-Match header value ("*", or a list of possibly weak tags) matches `etag`.
bool etag_matches(std::string_view if_none_match, std::string_view etag);

}  // namespace zoomwarp::api
