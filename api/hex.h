// Hexadecimal text of byte strings: API key digests in the key file, URL signatures, signing-key
// files. Lowercase out, either case in.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace zoomwarp::api {

inline bool is_hex_digit(char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F'); }

// The lowercase hex of `size` bytes at `bytes`.
inline std::string hex_encode(const unsigned char* bytes, std::size_t size) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(2 * size);
  for (std::size_t i = 0; i < size; ++i) out += {kDigits[bytes[i] >> 4], kDigits[bytes[i] & 15]};
  return out;
}

// The bytes an even number of hex digits stand for; nullopt for anything else.
inline std::optional<std::string> hex_decode(std::string_view hex) {
  auto value = [](char c) { return c <= '9' ? c - '0' : (c | 0x20) - 'a' + 10; };
  if (hex.size() % 2) return std::nullopt;
  std::string out;
  out.reserve(hex.size() / 2);
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    if (!is_hex_digit(hex[i]) || !is_hex_digit(hex[i + 1])) return std::nullopt;
    out += char(value(hex[i]) * 16 + value(hex[i + 1]));
  }
  return out;
}

}  // namespace zoomwarp::api
