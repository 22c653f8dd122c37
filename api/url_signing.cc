#include "api/url_signing.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <fstream>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <vector>

#include "api/hex.h"

namespace zoomwarp::api {

namespace {

using Mac = std::array<unsigned char, 32>;

Mac hmac_sha256(const std::string& key, std::string_view message) {
  Mac mac{};
  unsigned int size = 0;
  if (!HMAC(EVP_sha256(), key.data(), int(key.size()), reinterpret_cast<const unsigned char*>(message.data()),
            message.size(), mac.data(), &size) ||
      size != mac.size())
    throw std::runtime_error("HMAC-SHA256 failed");
  return mac;
}


std::string_view name_of(std::string_view pair) { return pair.substr(0, pair.find('=')); }

// The query's raw pairs but those named `drop_a` or `drop_b`, joined again in their order; the
// value of `sig` goes to *sig.
std::string without(std::string_view query, std::string_view drop_a, std::string_view drop_b,
                    std::string_view* sig = nullptr, std::string_view* expires = nullptr) {
  std::string kept;
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
    const std::string_view name = name_of(pair);
    const std::string_view value = pair.substr(std::min(pair.size(), name.size() + 1));
    if (sig && name == "sig") *sig = value;
    if (expires && name == "expires") *expires = value;
    if (name == drop_a || name == drop_b) continue;
    kept += (kept.empty() ? "" : "&") + std::string(pair);
  }
  return kept;
}

std::optional<std::int64_t> unix_seconds(std::string_view s) {
  if (s.empty() || s.size() > 12) return std::nullopt;
  std::int64_t v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return std::nullopt;
    v = v * 10 + (c - '0');
  }
  return v;
}

}  // namespace

bool is_signature_parameter(std::string_view name) { return name == "expires" || name == "sig"; }

UrlSigner::UrlSigner(std::string secret) : secret_(std::move(secret)) {
  if (secret_.size() < kMinSecretBytes)
    throw std::invalid_argument("a signing key has at least " + std::to_string(kMinSecretBytes) + " bytes");
}

UrlSigner UrlSigner::from_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read the signing key file " + path);
  const std::string raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string_view trimmed = raw;
  while (!trimmed.empty() && std::isspace(static_cast<unsigned char>(trimmed.back()))) trimmed.remove_suffix(1);
  while (!trimmed.empty() && std::isspace(static_cast<unsigned char>(trimmed.front()))) trimmed.remove_prefix(1);
  // Raw random bytes are all hex digits with negligible probability: content that is, is hex.
  const bool hex = !trimmed.empty() && std::all_of(trimmed.begin(), trimmed.end(), is_hex_digit);
  auto decoded = hex ? hex_decode(trimmed) : std::nullopt;
  if (hex && !decoded) throw std::runtime_error("the signing key file " + path + " holds an odd number of hex digits");
  std::string secret = decoded ? std::move(*decoded) : raw;
  if (secret.size() < kMinSecretBytes)
    throw std::runtime_error("the signing key file " + path + " holds fewer than " + std::to_string(kMinSecretBytes) +
                             " bytes (make one with: openssl rand -hex 32)");
  return UrlSigner(std::move(secret));
}

std::string UrlSigner::sign(std::string_view path, std::string_view query, std::int64_t expires) const {
  std::string signed_query = without(query, "expires", "sig");
  signed_query += (signed_query.empty() ? "expires=" : "&expires=") + std::to_string(expires);
  const std::string message = std::string(path) + "?" + signed_query;
  const Mac mac = hmac_sha256(secret_, message);
  return message + "&sig=" + hex_encode(mac.data(), mac.size());
}

UrlSigner::Verdict UrlSigner::verify(std::string_view path, std::string_view query, std::int64_t now) const {
  std::string_view sig, expires_text;
  const std::string signed_query = without(query, "sig", "", &sig, &expires_text);
  if (sig.data() == nullptr) return Verdict::kUnsigned;
  const auto given = hex_decode(sig);
  const auto expires = unix_seconds(expires_text);
  const Mac mac = hmac_sha256(secret_, std::string(path) + "?" + signed_query);
  // Constant time over the whole MAC: how much of a forged signature is right is not observable.
  if (!given || given->size() != mac.size() || !expires || CRYPTO_memcmp(given->data(), mac.data(), mac.size()) != 0)
    return Verdict::kBadSignature;
  return now > *expires ? Verdict::kExpired : Verdict::kValid;
}

namespace {
std::string service_message(std::string_view id, std::string_view expires) {
  return "iiif-image-service:" + std::string(id) + "~" + std::string(expires);
}
}  // namespace

std::string UrlSigner::sign_service(std::string_view id, std::int64_t expires) const {
  const std::string expires_text = std::to_string(expires);
  const Mac mac = hmac_sha256(secret_, service_message(id, expires_text));
  return std::string(id) + "~" + expires_text + "~" + hex_encode(mac.data(), mac.size());
}

UrlSigner::Verdict UrlSigner::verify_service(std::string_view segment, std::int64_t now, std::string* id) const {
  const std::size_t first = segment.find('~');
  *id = std::string(segment.substr(0, first));
  if (first == std::string_view::npos) return Verdict::kUnsigned;
  const std::size_t second = segment.find('~', first + 1);
  if (second == std::string_view::npos) return Verdict::kBadSignature;
  const std::string_view expires_text = segment.substr(first + 1, second - first - 1);
  const auto given = hex_decode(segment.substr(second + 1));
  const auto expires = unix_seconds(expires_text);
  const Mac mac = hmac_sha256(secret_, service_message(*id, expires_text));
  if (!given || given->size() != mac.size() || !expires || CRYPTO_memcmp(given->data(), mac.data(), mac.size()) != 0)
    return Verdict::kBadSignature;
  return now > *expires ? Verdict::kExpired : Verdict::kValid;
}

}  // namespace zoomwarp::api
