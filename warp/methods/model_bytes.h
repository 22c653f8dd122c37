// The methods' model-file payloads (analysis/method_files.h adds magic and trailer): fixed-width
// little-endian fields, written by ModelBytesWriter and read back by ModelBytesReader, which
// checks every field before it is used — a count never exceeds what the bytes left could hold,
// an index is in range, a number is finite — and throws std::runtime_error naming the model
// ("mp model: truncated"), so a damaged file is refused, never half-read.
//
// Thread safety: one object per thread.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>

namespace zoomwarp::warp {

static_assert(std::endian::native == std::endian::little, "model files are written little-endian");

class ModelBytesWriter {
 public:
  template <class T>
  void put(T v) {
    bytes_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void put_count(std::size_t n) { put(std::uint32_t(n)); }
  std::string take() { return std::move(bytes_); }

 private:
  std::string bytes_;
};

class ModelBytesReader {
 public:
  // `what` names the model in errors, e.g. "mp model".
  ModelBytesReader(std::string_view bytes, std::string what) : bytes_(bytes), what_(std::move(what)) {}

  template <class T>
  T get() {
    if (bytes_.size() < sizeof(T)) fail("truncated");
    T v;
    std::memcpy(&v, bytes_.data(), sizeof v);
    bytes_.remove_prefix(sizeof v);
    return v;
  }
  double number() {
    const double v = get<double>();
    if (!std::isfinite(v)) fail("a number is not finite");
    return v;
  }
  // A count of items at least `item_bytes` each: never more than the bytes left could hold.
  std::size_t count(std::size_t item_bytes) {
    const std::size_t n = get<std::uint32_t>();
    if (n * item_bytes > bytes_.size()) fail("a count exceeds the bytes left");
    return n;
  }
  // An index into something of `size` elements.
  int index(std::size_t size) {
    const std::int32_t i = get<std::int32_t>();
    if (i < 0 || std::size_t(i) >= size) fail("an index is out of range");
    return i;
  }
  // Throws unless every byte was read.
  void expect_done() {
    if (!bytes_.empty()) fail("trailing bytes");
  }
  [[noreturn]] void fail(const std::string& why) const { throw std::runtime_error(what_ + ": " + why); }

 private:
  std::string_view bytes_;
  std::string what_;
};

}  // namespace zoomwarp::warp
