// Strict parsing of what arrives in a URL: path segments, query parameters, numbers.
// Everything that is not exactly well-formed is rejected rather than guessed at.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace zoomwarp::api {

// Decodes %XX escapes; nullopt for a bad escape or a decoded NUL byte.
std::optional<std::string> percent_decode(std::string_view s, bool plus_is_space = false);

// Splits "/a/b%2Fc/" into decoded segments {"a", "b/c", ""}; nullopt if any segment is malformed.
std::optional<std::vector<std::string>> split_path(std::string_view path);

// Query "a=1&b=x" -> pairs, decoded; nullopt if malformed.
std::optional<std::vector<std::pair<std::string, std::string>>> parse_query(std::string_view q);

// A decimal integer of at most 9 digits without sign or spaces ("007" is fine, "1e3" is not).
std::optional<int> parse_small_uint(std::string_view s);

// A finite decimal number without exponent, such as "12", "0.5", ".5"; nullopt otherwise.
std::optional<double> parse_plain_decimal(std::string_view s);

}  // namespace zoomwarp::api
