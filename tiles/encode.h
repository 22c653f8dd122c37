// Encoders for responses: JPEG through libjpeg-turbo, PNG through libpng, WebP through libwebp,
// AVIF through libavif, JPEG XL through libjxl.
// Each takes a Raster of 1–4 channels; JPEG has no alpha, so RGBA is flattened onto white first.
#pragma once

#include <string>
#include <string_view>

#include "tiles/image_format.h"
#include "tiles/raster.h"

namespace zoomwarp::tiles {

struct EncodeOptions {
  int jpeg_quality = 85;  // 1…100
  int webp_quality = 80;  // 1…100, lossy
  int png_level = 3;      // zlib level 0…9: 3 is ~3× faster than 6 for a few % more bytes
  // AVIF: quality 60 at speed 10 matches JPEG 85's PSNR on a 480×360 view in 0.67 of its bytes,
  // in 14 ms against JPEG's 0.45 (speed 8: 0.64 of the bytes in 53 ms; tests/bench/encode_bench.cc,
  // tiles/README.md).
  int avif_quality = 60;  // 1…100
  int avif_speed = 10;    // libavif's 0 (slowest) … 10 (fastest)
  // JPEG XL: quality 1…100 as cjxl 0.7's --quality (Butteraugli distance 0.1 + (100 − q)·0.09
  // from 30 up); effort 1 (fastest) … 9 (tests/bench/encode_bench.cc, tiles/README.md).
  int jxl_quality = 80;  // 1…100
  int jxl_effort = 3;     // libjxl's 1 (fastest) … 9 (slowest)
};

// Largest width or height an AVIF answer may have: AV1 allows 65536, but its encoder's time and
// memory grow with the area.
inline constexpr int kAvifMaxDimension = 16384;

// Largest width or height a JPEG XL answer may have, for the same reason.
inline constexpr int kJxlMaxDimension = 16384;
// Largest width or height WebP can hold.
inline constexpr int kWebpMaxDimension = 16383;

// Throws std::invalid_argument for a raster the format cannot hold, std::runtime_error if the
// encoder fails.
std::string encode_image(const Raster& image, ImageFormat format, const EncodeOptions& options);

}  // namespace zoomwarp::tiles
