// Encoders for responses: JPEG through libjpeg-turbo, PNG through libpng, WebP through libwebp.
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
};

// Largest width or height WebP can hold.
inline constexpr int kWebpMaxDimension = 16383;

// Throws std::invalid_argument for a raster the format cannot hold, std::runtime_error if the
// encoder fails.
std::string encode_image(const Raster& image, ImageFormat format, const EncodeOptions& options);

}  // namespace zoomwarp::tiles
