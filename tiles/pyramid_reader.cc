#include "tiles/pyramid_reader.h"

#include <OpenImageIO/imagecache.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>

namespace zoomwarp::tiles {

struct PyramidReader::Impl {
  OIIO::ImageCache* cache = nullptr;
  std::int64_t limit = 0;
  // Counted here: get_pixels() does not go through the ImageCache's own find_tile statistics.
  std::atomic<std::int64_t> lookups{0};
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
  const OIIO::ustring file(image.level_path(level));
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
                                       OIIO::TypeDesc::UINT8, first, m.channels, row, OIIO::AutoStride))
        throw std::runtime_error("cannot read " + file.string() + ": " + cache.geterror());
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
  for (int k = 0; k < image.manifest.levels; ++k)
    impl_->cache->invalidate(OIIO::ustring(image.level_path(k)), true);
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
