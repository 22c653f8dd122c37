#include "tiles/pyramid_reader.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagecache.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "tiles/pyramid_builder.h"
#include "tiles/tiff_on_file.h"

namespace zoomwarp::tiles {

namespace {

// What a read of a remote level threw on this thread (ImageCache reads tiles on the calling
// thread): OpenImageIO only sees a short read, the caller rethrows this instead.
thread_local std::exception_ptr remote_read_failure;

// A level file read by byte range (a bucket's), handed to OpenImageIO's TIFF reader as its I/O.
// The ImageCache serialises the reads of one file; pread() may come from any thread.
class RangeProxy final : public OIIO::Filesystem::IOProxy {
 public:
  explicit RangeProxy(std::shared_ptr<const RandomAccessFile> file)
      : IOProxy(file->name(), Read), file_(std::move(file)) {}
  const char* proxytype() const override { return "zoomwarp_range"; }
  size_t read(void* buf, size_t size) override {
    const size_t got = pread(buf, size, m_pos);
    m_pos += int64_t(got);
    return got;
  }
  size_t pread(void* buf, size_t size, int64_t offset) override {
    try {
      return file_->read(std::uint64_t(offset), size, static_cast<char*>(buf));
    } catch (...) {
      if (!remote_read_failure) remote_read_failure = std::current_exception();
      return 0;
    }
  }
  size_t size() const override { return size_t(file_->size()); }

 private:
  const std::shared_ptr<const RandomAccessFile> file_;
};

}  // namespace

struct PyramidReader::Impl {
  OIIO::ImageCache* cache = nullptr;
  std::int64_t limit = 0;
  // Counted here: get_pixels() does not go through the ImageCache's own find_tile statistics.
  std::atomic<std::int64_t> lookups{0};
  // A remote level file the cache knows: its I/O, and where its stored tiles are (read once, for
  // prefetching the tiles a region needs side by side).
  struct RemoteLevel {
    std::shared_ptr<const RandomAccessFile> file;
    std::shared_ptr<RangeProxy> proxy;
    std::once_flag indexed;
    std::vector<ByteRange> tiles;  // by TIFF tile number: row-major
    // Tiles prefetched once: not again (a view reads the same tiles many times from the decoded
    // cache; should their bytes have left the range cache since, a read fetches them itself).
    std::unique_ptr<std::atomic<bool>[]> fetched;
  };
  // By the name the cache knows them by. Never dropped: the cache keeps each file's entry (and
  // its configuration, pointing here) for its lifetime, and may open an invalidated file again;
  // one is a few hundred bytes and its tile index, as the cache's own entry holds.
  std::mutex remote_mu;
  std::unordered_map<std::string, std::shared_ptr<RemoteLevel>> remote;

  // The name the cache reads level k of `image` by: its local path, or a remote file's location,
  // added to the cache with its I/O the first time (then also returned in `*level`).
  OIIO::ustring file_name(const ImageEntry& image, int k, std::shared_ptr<RemoteLevel>* level) {
    const std::string name = level_filename(k);
    if (std::optional<std::string> local = image.files->local_path(name)) return OIIO::ustring(*local);
    const std::string key = image.files->location() + "/" + name;
    {
      std::lock_guard lock(remote_mu);
      if (auto it = remote.find(key); it != remote.end()) {
        *level = it->second;
        return OIIO::ustring(key);
      }
    }
    auto opened = std::make_shared<RemoteLevel>();
    opened->file = image.files->open(name);
    if (!opened->file) throw std::runtime_error("cannot read " + key + ": missing");
    opened->proxy = std::make_shared<RangeProxy>(opened->file);
    std::lock_guard lock(remote_mu);
    auto [it, added] = remote.emplace(key, opened);
    if (added) {
      OIIO::ImageSpec config;
      void* io = opened->proxy.get();
      config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &io);
      cache->add_file(OIIO::ustring(key), nullptr, &config);
    }
    *level = it->second;
    return OIIO::ustring(key);
  }

  // Fetches the stored tiles of `r` (level pixels) that the store has not sent yet, side by side:
  // a region crossing rows of tiles waits for one round trip, not one per row.
  static void prefetch(RemoteLevel& level, const Manifest& m, int k, Rect r) {
    std::call_once(level.indexed, [&] {
      TiffOnFile tiff(level.file, nullptr);
      const std::uint32_t count = TIFFNumberOfTiles(tiff.tif());
      for (std::uint32_t i = 0; i < count; ++i) {
        int err = 0;
        const std::uint64_t offset = TIFFGetStrileOffsetWithErr(tiff.tif(), i, &err);
        const std::uint64_t length = err ? 0 : TIFFGetStrileByteCountWithErr(tiff.tif(), i, &err);
        level.tiles.push_back(err ? ByteRange{} : ByteRange{offset, length});
      }
      level.fetched = std::make_unique<std::atomic<bool>[]>(count);
    });
    const long long t = m.tile_size, across = (m.level_width(k) + t - 1) / t;
    std::vector<ByteRange> wanted;
    std::vector<std::size_t> numbers;
    for (long long ty = r.y / t; ty <= (r.y + r.h - 1) / t; ++ty)
      for (long long tx = r.x / t; tx <= (r.x + r.w - 1) / t; ++tx) {
        const std::size_t i = std::size_t(ty * across + tx);
        if (i >= level.tiles.size() || level.fetched[i].load(std::memory_order_relaxed)) continue;
        wanted.push_back(level.tiles[i]);
        numbers.push_back(i);
      }
    if (wanted.empty() || !level.file->prefetch(wanted)) return;
    for (std::size_t i : numbers) level.fetched[i].store(true, std::memory_order_relaxed);
  }

  // After a failed read: the store's failure, if that was why (a 503 stays a 503). The cache does
  // not remember a tile it could not read, so the next read asks the store again.
  static void rethrow_remote_failure() {
    if (!remote_read_failure) return;
    std::rethrow_exception(std::exchange(remote_read_failure, nullptr));
  }
};

PyramidReader::PyramidReader(std::size_t cache_bytes, int max_open_files)
    : impl_(std::make_unique<Impl>()) {
  impl_->cache = OIIO::ImageCache::create(/*shared=*/false);
  impl_->limit = std::int64_t(cache_bytes);
  impl_->cache->attribute("max_memory_MB", float(double(cache_bytes) / (1024.0 * 1024.0)));
  impl_->cache->attribute("max_open_files", max_open_files);
  impl_->cache->attribute("unassociatedalpha", 1);
  impl_->cache->attribute("autotile", 0);
  impl_->cache->attribute("forcefloat", 0);
  impl_->cache->attribute("failure_retries", 1);
}

PyramidReader::~PyramidReader() { OIIO::ImageCache::destroy(impl_->cache); }

Raster PyramidReader::read_level(const ImageEntry& image, int level, Rect r) {
  const Manifest& m = image.manifest;
  if (level < 0 || level >= m.levels || r.w <= 0 || r.h <= 0 || r.x < 0 || r.y < 0 ||
      r.x + r.w > m.level_width(level) || r.y + r.h > m.level_height(level))
    throw std::out_of_range("region outside the pyramid level");
  const long long t = m.tile_size;
  impl_->lookups += ((r.x + r.w - 1) / t - r.x / t + 1) * ((r.y + r.h - 1) / t - r.y / t + 1);
  Raster out(int(r.w), int(r.h), m.channels);
  std::shared_ptr<Impl::RemoteLevel> remote;
  const OIIO::ustring file = impl_->file_name(image, level, &remote);
  if (remote) Impl::prefetch(*remote, m, level, r);
  OIIO::ImageCache& cache = *impl_->cache;
  OIIO::ImageCache::Perthread* thread = cache.get_perthread_info();
  OIIO::ImageCache::ImageHandle* handle = cache.get_image_handle(file, thread);
  // One stored tile at a time: asked for a region several tiles wide, get_pixels walks it row by
  // row, and each row crossing tiles misses the per-thread tile microcache and searches the main
  // cache again (a 480×360 view's patch: thousands of searches instead of a dozen).
  const OIIO::stride_t row = OIIO::stride_t(out.row_bytes());
  for (long long ty = r.y / t * t; ty < r.y + r.h; ty += t)
    for (long long tx = r.x / t * t; tx < r.x + r.w; tx += t) {
      const long long x0 = std::max(tx, r.x), x1 = std::min(tx + t, r.x + r.w);
      const long long y0 = std::max(ty, r.y), y1 = std::min(ty + t, r.y + r.h);
      std::uint8_t* first = out.pixels.data() + (y0 - r.y) * row + (x0 - r.x) * m.channels;
      if (!handle || !cache.get_pixels(handle, thread, 0, 0, int(x0), int(x1), int(y0), int(y1), 0, 1, 0, m.channels,
                                       OIIO::TypeDesc::UINT8, first, m.channels, row, OIIO::AutoStride)) {
        const std::string error = cache.geterror();
        Impl::rethrow_remote_failure();
        throw std::runtime_error("cannot read " + file.string() + ": " + error);
      }
    }
  return out;
}

int level_for_shrink(double shrink, int levels) {
  if (!(shrink > 1.0)) return 0;
  int k = int(std::floor(std::log2(shrink) + 1e-9));
  return std::clamp(k, 0, levels - 1);
}

Raster PyramidReader::read_scaled(const ImageEntry& image, Rect region, int out_w, int out_h) {
  const Manifest& m = image.manifest;
  const double shrink = std::min(double(region.w) / out_w, double(region.h) / out_h);
  const int k = level_for_shrink(shrink, m.levels);
  const double f = std::ldexp(1.0, -k);
  // The level-k pixels that cover the region (snapped outwards to whole pixels).
  const long long x0 = (long long)std::floor(region.x * f), y0 = (long long)std::floor(region.y * f);
  const long long x1 = std::min<long long>((long long)std::ceil((region.x + region.w) * f), m.level_width(k));
  const long long y1 = std::min<long long>((long long)std::ceil((region.y + region.h) * f), m.level_height(k));
  Raster src = read_level(image, k, Rect{x0, y0, std::max(1LL, x1 - x0), std::max(1LL, y1 - y0)});
  if (src.width == out_w && src.height == out_h) return src;

  // The chosen level is at most 2× finer than the output, so area averaging (INTER_AREA) is an
  // exact box filter with no aliasing; enlarging (IIIF "^" sizes) interpolates bicubically.
  // OpenCV's are ~100× faster here than OpenImageIO's general-purpose filtered resize.
  Raster out(out_w, out_h, src.channels);
  const cv::Mat in(src.height, src.width, CV_8UC(src.channels), src.pixels.data());
  cv::Mat dst(out_h, out_w, CV_8UC(src.channels), out.pixels.data());
  const bool shrinking = out_w <= src.width && out_h <= src.height;
  cv::resize(in, dst, dst.size(), 0, 0, shrinking ? cv::INTER_AREA : cv::INTER_CUBIC);
  return out;
}

void PyramidReader::forget(const ImageEntry& image) {
  for (int k = 0; k < image.manifest.levels; ++k) {
    const std::string name = level_filename(k);
    const std::optional<std::string> local = image.files->local_path(name);
    const std::string file = local ? *local : image.files->location() + "/" + name;
    impl_->cache->invalidate(OIIO::ustring(file), true);
  }
}

PyramidReader::Stats PyramidReader::stats() const {
  Stats s;
  int created = 0;
  long long used = 0;
  impl_->cache->getattribute("stat:tiles_created", created);
  impl_->cache->getattribute("stat:cache_memory_used", OIIO::TypeDesc::INT64, &used);
  s.lookups = impl_->lookups.load();
  s.tiles_read = created;
  s.bytes_used = used;
  s.bytes_limit = impl_->limit;
  return s;
}

}  // namespace zoomwarp::tiles
