// Reads pixels out of stored pyramids through OpenImageIO's ImageCache, which keeps decoded tiles
// in memory up to a byte limit (the decoded-tile cache) and opens files lazily, a bounded number
// at a time. Safe to use from many threads at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "tiles/raster.h"
#include "tiles/store.h"

namespace zoomwarp::tiles {

class PyramidReader {
 public:
  explicit PyramidReader(std::size_t cache_bytes, int max_open_files = 200);
  ~PyramidReader();
  PyramidReader(const PyramidReader&) = delete;
  PyramidReader& operator=(const PyramidReader&) = delete;

  // Pixels of rectangle `r` of pyramid level `level` (r must lie inside the level), as stored
  // (manifest.channels). Throws std::runtime_error if the files cannot be read.
  Raster read_level(const ImageEntry& image, int level, Rect r);

  // The full-resolution rectangle `region` scaled to out_w × out_h: read from the coarsest level
  // that still has at least the output's resolution, resampled only when sizes differ (a tile
  // request that matches a level is copied exactly).
  Raster read_scaled(const ImageEntry& image, Rect region, int out_w, int out_h);

  // Drops cached tiles and open files of an image version (after it was deleted).
  void forget(const ImageEntry& image);

  struct Stats {
    std::int64_t lookups = 0;     // tiles the reads covered (each one a lookup)
    std::int64_t tiles_read = 0;  // tiles decoded from disk (misses)
    std::int64_t bytes_used = 0;
    std::int64_t bytes_limit = 0;
  };
  Stats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The pyramid level to read for a region shrunk by `shrink` (≥ 1 means the output is smaller):
// the largest k with 2^k ≤ shrink, clamped to the levels that exist.
int level_for_shrink(double shrink, int levels);

}  // namespace zoomwarp::tiles
