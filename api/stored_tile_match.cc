#include "api/stored_tile_match.h"

#include <algorithm>
#include <cstdint>

#include "tiles/pyramid_reader.h"
#include "tiles/stored_tiles.h"

namespace zoomwarp::api {

namespace {

// The stored tile whose pixels are exactly `r` of level k (an edge tile is clipped), or nullopt.
std::optional<StoredTileRef> whole_tile(const tiles::Manifest& m, int k, const tiles::Rect& r) {
  const std::int64_t ts = m.tile_size;
  if (r.x % ts != 0 || r.y % ts != 0) return std::nullopt;
  if (r.w != std::min<std::int64_t>(ts, m.level_width(k) - r.x) || r.h != std::min<std::int64_t>(ts, m.level_height(k) - r.y))
    return std::nullopt;
  return StoredTileRef{k, int(r.x / ts), int(r.y / ts)};
}

}  // namespace

std::optional<StoredTileRef> iiif_stored_tile(const tiles::Manifest& m, const IiifPlan& plan) {
  if (!tiles::has_jpeg_tiles(m) || plan.format != tiles::ImageFormat::kJpeg || plan.rotation != 0 || plan.mirror ||
      (plan.quality != IiifQuality::kDefault && plan.quality != IiifQuality::kColor))
    return std::nullopt;
  // The level and the level-k pixels read_scaled reads for this plan (tiles/pyramid_reader.cc).
  const tiles::Rect& g = plan.region;
  const int k = tiles::level_for_shrink(std::min(double(g.w) / plan.width, double(g.h) / plan.height), m.levels);
  const std::int64_t scale = std::int64_t(1) << k, x0 = g.x >> k, y0 = g.y >> k;
  const std::int64_t x1 = std::min<std::int64_t>((g.x + g.w + scale - 1) >> k, m.level_width(k));
  const std::int64_t y1 = std::min<std::int64_t>((g.y + g.h + scale - 1) >> k, m.level_height(k));
  if (x1 - x0 != plan.width || y1 - y0 != plan.height) return std::nullopt;  // resampled: not a copy
  return whole_tile(m, k, tiles::Rect{x0, y0, x1 - x0, y1 - y0});
}

std::optional<StoredTileRef> dzi_stored_tile(const tiles::Manifest& m, const DziLayout& layout, const DziTile& tile,
                                             tiles::ImageFormat format) {
  if (!tiles::has_jpeg_tiles(m) || format != tiles::ImageFormat::kJpeg || layout.overlap != 0 ||
      layout.tile_size != m.tile_size)
    return std::nullopt;
  return whole_tile(m, tile.store_level, tile.rect);
}

}  // namespace zoomwarp::api
