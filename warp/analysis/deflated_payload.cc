#include "warp/analysis/deflated_payload.h"

#include <libdeflate.h>

#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>

#include "warp/analysis/model_file.h"

namespace zoomwarp::warp {

namespace {

// libdeflate's level 9, its strongest short of the near-optimal parsing of 10–12: a file is
// written once per version and read on every engine load, and inflating costs the same at any
// level.
constexpr int kLevel = 9;

constexpr std::size_t kSizeBytes = sizeof(std::uint64_t);

}  // namespace

std::string deflated(std::string_view payload) {
  std::unique_ptr<libdeflate_compressor, decltype(&libdeflate_free_compressor)> c(libdeflate_alloc_compressor(kLevel),
                                                                                  &libdeflate_free_compressor);
  if (!c) throw std::bad_alloc();
  const std::uint64_t size = payload.size();
  std::string out(kSizeBytes + libdeflate_deflate_compress_bound(c.get(), payload.size()), '\0');
  std::memcpy(out.data(), &size, kSizeBytes);
  const std::size_t n =
      libdeflate_deflate_compress(c.get(), payload.data(), payload.size(), out.data() + kSizeBytes, out.size() - kSizeBytes);
  // The bound is libdeflate's worst case for this compressor: compression cannot fail.
  if (n == 0) throw std::logic_error("libdeflate exceeded its own bound");
  out.resize(kSizeBytes + n);
  return out;
}

std::string inflated(const char* file, std::string_view bytes, std::size_t max_bytes) {
  if (bytes.size() < kSizeBytes) throw ModelFileError(file, "truncated");
  std::uint64_t size;
  std::memcpy(&size, bytes.data(), kSizeBytes);
  if (size > max_bytes) throw ModelFileError(file, "states an inflated size beyond the limit");
  std::unique_ptr<libdeflate_decompressor, decltype(&libdeflate_free_decompressor)> d(libdeflate_alloc_decompressor(),
                                                                                      &libdeflate_free_decompressor);
  if (!d) throw std::bad_alloc();
  std::string out(size, '\0');
  // A null actual size: libdeflate answers SHORT_OUTPUT unless the stream fills `out` exactly.
  const libdeflate_result r = libdeflate_deflate_decompress(d.get(), bytes.data() + kSizeBytes, bytes.size() - kSizeBytes,
                                                            out.data(), out.size(), nullptr);
  if (r != LIBDEFLATE_SUCCESS) throw ModelFileError(file, "does not inflate to the size it states");
  return out;
}

}  // namespace zoomwarp::warp
