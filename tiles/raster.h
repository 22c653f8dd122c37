// A plain 8-bit interleaved pixel buffer: the currency between the store, the resamplers and the
// encoders. Row-major, `channels` bytes per pixel, no padding between rows.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace zoomwarp::tiles {

struct Raster {
  int width = 0;
  int height = 0;
  int channels = 0;  // 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA (alpha is straight, not premultiplied)
  std::vector<std::uint8_t> pixels;

  Raster() = default;
  Raster(int w, int h, int c) : width(w), height(h), channels(c), pixels(std::size_t(w) * h * c) {}

  std::size_t row_bytes() const { return std::size_t(width) * channels; }
  std::uint8_t* row(int y) { return pixels.data() + std::size_t(y) * row_bytes(); }
  const std::uint8_t* row(int y) const { return pixels.data() + std::size_t(y) * row_bytes(); }
  bool empty() const { return width <= 0 || height <= 0; }
};

// A pixel rectangle [x, x+w) × [y, y+h).
struct Rect {
  long long x = 0, y = 0, w = 0, h = 0;
  friend bool operator==(const Rect&, const Rect&) = default;
};

}  // namespace zoomwarp::tiles
