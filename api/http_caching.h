// HTTP caching for immutable image versions: strong ETags from the image version and the request,
// Last-Modified from the publish time, and the If-None-Match / If-Match conditions (RFC 9110 §13.1).
// Pure functions: safe from any thread.
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

// Whether an If-None-Match header value ("*", or a comma-separated list of entity tags) matches
// the current `etag`, by weak comparison (RFC 9110 §13.1.2): W/"x" matches "x".
bool if_none_match_matches(std::string_view header, std::string_view etag);

// Whether an If-Match header value ("*", or a list of entity tags) matches the current `etag`, by
// strong comparison (RFC 9110 §13.1.1): a weak tag W/"x" never matches, "*" matches any current
// representation. A malformed list matches nothing (the edit is refused, not guessed at).
bool if_match_matches(std::string_view header, std::string_view etag);

}  // namespace zoomwarp::api
