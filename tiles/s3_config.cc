#include "tiles/s3_config.h"

#include <cstdlib>
#include <vector>

namespace zoomwarp::tiles {

namespace {

bool has_line_break(std::string_view s) { return s.find_first_of("\r\n") != std::string_view::npos; }

bool valid_region(std::string_view r) {
  if (r.empty() || r.size() > 64) return false;
  // The region is a field of libcurl's "aws:amz:REGION:s3" and of the host name: a ':' or '.'
  // there would sign for something else than what is asked.
  for (char c : r)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) return false;
  return true;
}

// "scheme://host[:port]" with an optional trailing '/', returned without it; nullopt otherwise.
// A path is refused rather than kept: behind a proxy that strips it, the path the server
// canonicalises would not be the path signed.
std::optional<std::string> normalised_endpoint(std::string_view e) {
  std::string_view rest;
  if (e.starts_with("http://")) rest = e.substr(7);
  else if (e.starts_with("https://")) rest = e.substr(8);
  else return std::nullopt;
  if (rest.ends_with('/')) rest.remove_suffix(1);
  if (rest.empty()) return std::nullopt;
  for (char c : rest)
    if (c == '/' || c == '?' || c == '#' || c == '@' || c == ' ' || static_cast<unsigned char>(c) < 0x20)
      return std::nullopt;
  return std::string(e.substr(0, e.size() - (e.ends_with('/') ? 1 : 0)));
}

bool is_ipv4(std::string_view s) {
  int parts = 0;
  std::size_t i = 0;
  while (i <= s.size()) {
    std::size_t j = s.find('.', i);
    if (j == std::string_view::npos) j = s.size();
    const std::string_view part = s.substr(i, j - i);
    if (part.empty() || part.size() > 3) return false;
    for (char c : part)
      if (c < '0' || c > '9') return false;
    ++parts;
    i = j + 1;
  }
  return parts == 4;
}

}  // namespace

std::string s3_uri_encode(std::string_view s, bool keep_slash) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  out.reserve(s.size());
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '.' ||
        c == '_' || c == '~' || (c == '/' && keep_slash)) {
      out += ch;
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

bool valid_bucket_name(std::string_view b) {
  if (b.size() < 3 || b.size() > 63) return false;
  for (char c : b)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '-')) return false;
  auto alnum = [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9'); };
  if (!alnum(b.front()) || !alnum(b.back())) return false;
  if (b.find("..") != std::string_view::npos || b.find(".-") != std::string_view::npos ||
      b.find("-.") != std::string_view::npos)
    return false;
  if (is_ipv4(b)) return false;
  if (b.starts_with("xn--") || b.starts_with("sthree-") || b.ends_with("-s3alias") || b.ends_with("--ol-s3"))
    return false;
  return true;
}

S3Config::S3Config(std::string access_key_id, std::string secret_access_key, std::string region,
                   std::string endpoint, std::string session_token) {
  if (access_key_id.empty()) throw S3ConfigError("S3: the access key id is empty");
  if (secret_access_key.empty()) throw S3ConfigError("S3: the secret access key is empty");
  // The token travels in a header; the key and secret are handed to libcurl, which signs with them.
  if (has_line_break(access_key_id) || has_line_break(secret_access_key) || has_line_break(session_token))
    throw S3ConfigError("S3: a credential holds a line break");
  *this = S3Config(fixed_credentials({std::move(access_key_id), std::move(secret_access_key), std::move(session_token),
                                      std::nullopt}),
                   std::move(region), std::move(endpoint));
}

S3Config::S3Config(std::shared_ptr<S3CredentialSource> credentials, std::string region, std::string endpoint)
    : credentials_(std::move(credentials)), region_(std::move(region)) {
  if (!credentials_) throw S3ConfigError("S3: no credential source");
  if (!valid_region(region_))
    throw S3ConfigError("S3: region '" + region_ + "' is not a region name (lower-case letters, digits, '-')");
  if (!endpoint.empty()) {
    auto e = normalised_endpoint(endpoint);
    if (!e) throw S3ConfigError("S3: endpoint '" + endpoint + "' is not http(s)://host[:port]");
    endpoint_ = std::move(*e);
  }
}

S3Config S3Config::from_environment() {
  return from_environment([](const char* name) -> std::optional<std::string> {
    const char* v = std::getenv(name);
    if (v == nullptr) return std::nullopt;
    return std::string(v);
  });
}

S3Config S3Config::from_environment(
    const std::function<std::optional<std::string>(const char* name)>& lookup) {
  auto get = [&](const char* name) -> std::string {
    auto v = lookup(name);
    return v ? *v : std::string();
  };
  std::string region_var = "AWS_REGION";
  std::string region = get("AWS_REGION");
  if (region.empty()) {
    region_var = "AWS_DEFAULT_REGION";
    region = get("AWS_DEFAULT_REGION");
  }
  if (region.empty()) region = kDefaultRegion;
  std::string endpoint_var = "AWS_ENDPOINT_URL_S3";
  std::string endpoint = get("AWS_ENDPOINT_URL_S3");
  if (endpoint.empty()) {
    endpoint_var = "AWS_ENDPOINT_URL";
    endpoint = get("AWS_ENDPOINT_URL");
  }
  // Errors name the variable at fault rather than the constructor's generic wording.
  if (has_line_break(get("AWS_ACCESS_KEY_ID")) || has_line_break(get("AWS_SECRET_ACCESS_KEY")) ||
      has_line_break(get("AWS_SESSION_TOKEN")))
    throw S3ConfigError("AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY or AWS_SESSION_TOKEN holds a line break");
  if (!valid_region(region))
    throw S3ConfigError(region_var + "='" + region + "' is not a region name (lower-case letters, digits, '-')");
  if (!endpoint.empty() && !normalised_endpoint(endpoint))
    throw S3ConfigError(endpoint_var + "='" + endpoint + "' is not http(s)://host[:port]");
  return S3Config(credentials_from_environment(lookup, region), region, endpoint);
}

std::string S3Config::url(std::string_view bucket, std::string_view key, std::string_view query) const {
  std::string u;
  const std::string encoded_key = s3_uri_encode(key, true);
  if (path_style()) {
    u = endpoint_ + "/" + std::string(bucket);
    if (!key.empty()) u += "/" + encoded_key;
  } else if (bucket.find('.') != std::string_view::npos) {
    u = "https://s3." + region_ + ".amazonaws.com/" + std::string(bucket);
    if (!key.empty()) u += "/" + encoded_key;
  } else {
    u = "https://" + std::string(bucket) + ".s3." + region_ + ".amazonaws.com/" + encoded_key;
  }
  if (!query.empty()) u += "?" + std::string(query);
  return u;
}

std::string S3Config::describe() const {
  if (path_style()) return endpoint_ + " (path-style, " + region_ + ")";
  return "AWS S3 (" + region_ + ")";
}

std::string S3Location::url() const { return "s3://" + bucket + "/" + prefix; }

S3Location parse_s3_location(std::string_view url) {
  if (!url.starts_with("s3://"))
    throw S3ConfigError("'" + std::string(url) + "' is not an s3://BUCKET/PREFIX location");
  std::string_view rest = url.substr(5);
  const std::size_t slash = rest.find('/');
  const std::string_view bucket = rest.substr(0, slash);
  std::string_view prefix = slash == std::string_view::npos ? std::string_view() : rest.substr(slash);
  if (!valid_bucket_name(bucket))
    throw S3ConfigError("'" + std::string(url) + "': '" + std::string(bucket) +
                        "' is not a valid bucket name (3-63 characters of a-z 0-9 . -, starting and ending with a "
                        "letter or digit)");
  for (char c : prefix)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      throw S3ConfigError("'" + std::string(url) + "': the prefix holds a control character");
  while (prefix.starts_with('/')) prefix.remove_prefix(1);
  S3Location l{std::string(bucket), std::string(prefix)};
  if (!l.prefix.empty() && !l.prefix.ends_with('/')) l.prefix += '/';
  return l;
}

}  // namespace zoomwarp::tiles
