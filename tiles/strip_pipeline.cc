#include "tiles/strip_pipeline.h"

#include <algorithm>
#include <chrono>
#include <future>

#include "tiles/helping_wait.h"

namespace zoomwarp::tiles {

struct StripPipeline::Pool {
  explicit Pool(int helpers) : threads(helpers) {}
  OIIO::thread_pool threads;  // 0 threads: push() runs the task at once on the caller
};

struct StripPipeline::Strip {
  LevelFile* file;
  TileEncoder encoder;
  int ty, width, rows;
  std::unique_ptr<std::uint8_t[]> pixels;
  std::vector<std::vector<std::uint8_t>> tiles;  // encoded, one per tile column
  std::vector<std::future<void>> encoded;        // one per tile column

  std::size_t bytes() const { return std::size_t(encoder.tile_size()) * width * encoder.channels(); }

  // Cuts tile column `tx` out of the strip, padded to a whole tile, and encodes it. Runs on any
  // thread; touches only the pixels (read) and tiles[tx].
  //
  // The padding repeats the edge pixels up to one JPEG MCU (16 px, the largest) past the MCU the
  // edge is in — so that every block a decoder reads for a pixel inside the image, chroma
  // upsampling's neighbours included, is coded as if the image went on (no ringing into it) — and
  // is one flat colour beyond, the cheapest block to code, for JPEG and for deflate alike. A
  // small image's coarse levels are one tile each, mostly padding: repeated edges made stripes
  // that cost a 1 MP photograph's pyramid about a tenth of its bytes (issue 28).
  void encode_tile(int tx) {
    constexpr int kMcu = 16;
    const int ts = encoder.tile_size();
    const std::size_t px = std::size_t(encoder.channels());
    thread_local std::vector<std::uint8_t> tile;
    tile.resize(std::size_t(ts) * ts * px);
    const int x0 = tx * ts, cols = std::min(ts, width - x0);
    const auto guarded = [&](int n) { return std::min(ts, (n + kMcu - 1) / kMcu * kMcu + kMcu); };
    const int repeat_cols = guarded(cols), repeat_rows = guarded(rows);
    const std::uint8_t* flat = pixels.get() + (std::size_t(rows - 1) * width + x0 + cols - 1) * px;
    for (int r = 0; r < ts; ++r) {
      std::uint8_t* dst = tile.data() + std::size_t(r) * ts * px;
      int c = 0;
      if (r < repeat_rows) {
        const std::uint8_t* src = pixels.get() + (std::size_t(std::min(r, rows - 1)) * width + x0) * px;
        std::copy_n(src, cols * px, dst);
        for (c = cols; c < repeat_cols; ++c) std::copy_n(src + (cols - 1) * px, px, dst + c * px);
      }
      for (; c < ts; ++c) std::copy_n(flat, px, dst + c * px);
    }
    tiles[std::size_t(tx)] = encoder(tile);
  }
};

namespace {

bool ready(const std::future<void>& f) { return f.wait_for(std::chrono::seconds(0)) == std::future_status::ready; }

}  // namespace

StripPipeline::StripPipeline(int threads, std::size_t max_pixel_bytes)
    : pool_(std::make_unique<Pool>(std::max(threads, 1) - 1)), max_pixel_bytes_(max_pixel_bytes) {}

StripPipeline::~StripPipeline() {
  // After a failure: the tasks still queued or running read strips that are about to go.
  for (auto& s : strips_)
    for (auto& f : s->encoded)
      if (f.valid()) f.wait();
}

void StripPipeline::submit(LevelFile& file, int ty, int width, int rows, std::unique_ptr<std::uint8_t[]> pixels) {
  const int columns = (width + file.encoder().tile_size() - 1) / file.encoder().tile_size();
  auto strip = std::make_unique<Strip>(Strip{&file, file.encoder(), ty, width, rows, std::move(pixels), {}, {}});
  strip->tiles.resize(std::size_t(columns));
  strip->encoded.reserve(std::size_t(columns));
  Strip* s = strip.get();
  pixel_bytes_ += s->bytes();
  strips_.push_back(std::move(strip));
  for (int tx = 0; tx < columns; ++tx) s->encoded.push_back(pool_->threads.push([s, tx](int) { s->encode_tile(tx); }));
  write_finished();
  while (pixel_bytes_ > max_pixel_bytes_) write_front();
}

void StripPipeline::drain() {
  while (!strips_.empty()) write_front();
}

void StripPipeline::write_front() {
  Strip& s = *strips_.front();
  for (auto& f : s.encoded) {
    wait_helping(pool_->threads, f);  // compressing queued tiles of any strip meanwhile
    f.get();                           // rethrows the tile's failure
  }
  for (std::size_t tx = 0; tx < s.tiles.size(); ++tx) s.file->write(int(tx), s.ty, s.tiles[tx]);
  pixel_bytes_ -= s.bytes();
  if (spare_bytes_ + s.bytes() <= 2 * max_pixel_bytes_) {
    spare_bytes_ += s.bytes();
    spare_.emplace_back(s.bytes(), std::move(s.pixels));
  }
  strips_.pop_front();
}

std::unique_ptr<std::uint8_t[]> StripPipeline::strip_buffer(std::size_t bytes) {
  const auto it = std::find_if(spare_.begin(), spare_.end(), [bytes](const auto& b) { return b.first == bytes; });
  if (it == spare_.end()) return std::make_unique_for_overwrite<std::uint8_t[]>(bytes);
  auto buffer = std::move(it->second);
  spare_bytes_ -= bytes;
  spare_.erase(it);
  return buffer;
}

void StripPipeline::write_finished() {
  while (!strips_.empty() && std::all_of(strips_.front()->encoded.begin(), strips_.front()->encoded.end(), ready))
    write_front();
}

}  // namespace zoomwarp::tiles
