#include "api/http_caching.h"

#include <ctime>
#include <optional>
#include <vector>

namespace zoomwarp::api {

std::uint64_t fnv1a64(std::string_view data, std::uint64_t h) {
  for (unsigned char c : data) h = (h ^ c) * 1099511628211ULL;
  return h;
}

std::string hex64(std::uint64_t v) {
  static const char* digits = "0123456789abcdef";
  std::string hex(16, '0');
  for (int i = 15; i >= 0; --i, v >>= 4) hex[std::size_t(i)] = digits[v & 15];
  return hex;
}

std::string make_etag(std::string_view version, std::string_view key) {
  return "\"" + std::string(version) + "-" + hex64(fnv1a64(key)) + "\"";
}

std::string http_date(std::int64_t unix_ms) {
  std::time_t t = std::time_t(unix_ms / 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "%a, %d %b %Y %H:%M:%S GMT", &tm);
  return buf;
}

namespace {

struct EntityTag {
  bool weak = false;
  std::string_view opaque;  // with its quotes, as make_etag() writes it
};

// Parses #entity-tag (RFC 9110 §8.8.3): tags separated by commas and optional white space; a tag's
// quoted part may itself hold commas. nullopt if the list is malformed.
std::optional<std::vector<EntityTag>> parse_entity_tags(std::string_view s) {
  std::vector<EntityTag> tags;
  std::size_t i = 0;
  auto skip_separators = [&] {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == ',')) ++i;
  };
  for (skip_separators(); i < s.size(); skip_separators()) {
    EntityTag tag;
    if (s.substr(i, 2) == "W/") tag.weak = true, i += 2;
    if (i >= s.size() || s[i] != '"') return std::nullopt;
    const std::size_t close = s.find('"', i + 1);
    if (close == std::string_view::npos) return std::nullopt;
    tag.opaque = s.substr(i, close + 1 - i);
    i = close + 1;
    if (i < s.size() && s[i] != ',' && s[i] != ' ' && s[i] != '\t') return std::nullopt;
    tags.push_back(tag);
  }
  return tags;
}

bool is_star(std::string_view header) {
  while (!header.empty() && (header.front() == ' ' || header.front() == '\t')) header.remove_prefix(1);
  while (!header.empty() && (header.back() == ' ' || header.back() == '\t')) header.remove_suffix(1);
  return header == "*";
}

bool any_matches(std::string_view header, std::string_view etag, bool strong) {
  if (is_star(header)) return true;  // every image response has a current representation
  const auto tags = parse_entity_tags(header);
  if (!tags) return false;
  for (const EntityTag& t : *tags)
    if (t.opaque == etag && !(strong && t.weak)) return true;
  return false;
}

}  // namespace

bool if_none_match_matches(std::string_view header, std::string_view etag) { return any_matches(header, etag, false); }

bool if_match_matches(std::string_view header, std::string_view etag) { return any_matches(header, etag, true); }

}  // namespace zoomwarp::api
