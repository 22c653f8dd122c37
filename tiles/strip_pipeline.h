// Encodes strips of tiles on a pool of threads and writes them in the order they were given.
//
// Ingest's producer (decoding and halving, pyramid_builder.cc) hands each finished strip — one
// row of tiles of one level — to submit(); its tiles are padded and compressed by the pool while
// the producer decodes on, and each strip is written to its LevelFile by the producer once it and
// every strip given before it are encoded. So a file's tiles are written in the same order
// whatever the thread count, and its bytes are the same. The pixels of strips given but not yet
// written are bounded (`max_pixel_bytes`): past the bound, submit() waits for the oldest strip,
// compressing queued tiles itself meanwhile, so `threads` threads are busy, never more.
//
// Thread safety: one producer thread calls submit() and drain(); the pool's threads only read a
// strip's pixels and write its tiles' bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <utility>
#include <vector>

#include "tiles/level_file.h"

namespace zoomwarp::tiles {

class StripPipeline {
 public:
  // `threads` ≥ 1 counts the producer: threads - 1 helpers (none: everything runs in submit()).
  StripPipeline(int threads, std::size_t max_pixel_bytes);
  ~StripPipeline();  // waits for tiles still being encoded; writes nothing more
  StripPipeline(const StripPipeline&) = delete;
  StripPipeline& operator=(const StripPipeline&) = delete;

  // Tile row `ty` of `file`: `rows` (1 … tile size) rows of `width` pixels at the start of
  // `pixels`, a strip of tile-size rows. Rows and columns short of a whole tile are padded by
  // repeating the last ones (they then compress to almost nothing and hold no stale memory).
  // `file` must outlive drain(). Throws what encoding or writing an earlier strip threw.
  void submit(LevelFile& file, int ty, int width, int rows, std::unique_ptr<std::uint8_t[]> pixels);

  // Encodes and writes everything submitted. Throws as submit() does.
  void drain();

  // A buffer of `bytes` for a strip's pixels, not zeroed: one that a written strip of that size
  // left, or a new one. Recycled because every strip a fresh allocation cost the 952 MP image
  // ~2.8 GB of page faults, and glibc growing and trimming its heap around them, a third of the
  // ingest's CPU — much of it on the decoding thread, the critical path (docs/ingest.md).
  std::unique_ptr<std::uint8_t[]> strip_buffer(std::size_t bytes);

 private:
  struct Strip;
  struct Pool;
  void write_front();       // waits for the oldest strip (helping), writes it, drops it
  void write_finished();    // writes the oldest strips as long as they are already encoded

  std::unique_ptr<Pool> pool_;
  const std::size_t max_pixel_bytes_;
  std::size_t pixel_bytes_ = 0;  // of the strips in strips_ (given, not yet written)
  std::deque<std::unique_ptr<Strip>> strips_;
  // Pixel buffers of written strips, by size, kept for strip_buffer() up to 2 × max_pixel_bytes_
  // (a level's strips are all one size; every level together is under twice level 0's).
  std::vector<std::pair<std::size_t, std::unique_ptr<std::uint8_t[]>>> spare_;
  std::size_t spare_bytes_ = 0;
};

}  // namespace zoomwarp::tiles
