// Image helpers for tests: decode what the server sent, read reference files, compare pixels.
// References are computed with OpenImageIO directly from the source files, independently of the
// code under test.
#pragma once

#include <string>

#include "tiles/raster.h"

namespace zoomwarp::testing {

// Decodes encoded image bytes (JPEG, PNG, WebP, AVIF, JPEG XL) to 8-bit; throws on failure.
tiles::Raster decode_image(const std::string& bytes);

// Reads an image file as 8-bit with its own channels, EXIF orientation applied.
tiles::Raster load_image(const std::string& path);

tiles::Raster crop(const tiles::Raster& in, tiles::Rect r);

// OpenImageIO's filtered resize (a different filter from the server's 2×2 pyramid).
tiles::Raster resize(const tiles::Raster& in, int w, int h);

// Keeps the first `channels` channels (e.g. RGB of RGBA).
tiles::Raster take_channels(const tiles::Raster& in, int channels);

// Peak signal-to-noise ratio in dB over all samples; infinity when identical. Sizes must match.
double psnr(const tiles::Raster& a, const tiles::Raster& b);

// Writes a raster with OpenImageIO (format from the extension); `bits` 8 or 16;
// `orientation` is stored as EXIF orientation when not 1; `quality` (1…100) for JPEG and WebP,
// 0 for OpenImageIO's default.
void write_image(const std::string& path, const tiles::Raster& r, int bits = 8, int orientation = 1, int quality = 0);

// A deterministic test picture with structure at all scales (gradients, a grid, text-like dots).
tiles::Raster test_pattern(int w, int h, int channels);

}  // namespace zoomwarp::testing
