#include "warp/render/rendered_tiles.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "warp/render/level_patch.h"

namespace zoomwarp::warp {

namespace {

using Tile = std::shared_ptr<const tiles::Raster>;

// A kept tile's bookkeeping besides its pixels: key, map and list nodes, control block.
constexpr std::size_t kTileOverhead = 256;

// Levels down to one pixel: a view never minifies a level by more than 2× (level_for).
int level_count(const RenderedTiles::Image& image) {
  const double side = std::max({image.tw, image.th, 1.0});
  return 1 + int(std::ceil(std::log2(side)));
}

// Waits for another request's tile, giving up when this request's own time runs out.
void wait_for(const std::shared_future<Tile>& pending, const StopToken* stop) {
  if (!stop) return pending.wait();
  while (pending.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) stop->check();
}

// Level pixels x0 … x1 − 1 × y0 … y1 − 1 copied out of the tiles that cover them.
tiles::Raster assemble(RenderedTiles& tiles, const RenderedTiles::Image& image, int level, long long x0, long long y0,
                       long long x1, long long y1, const RenderedTiles::DrawTile& draw, const StopToken* stop) {
  constexpr long long T = RenderedTiles::kTileSize;
  const int c = image.channels;
  tiles::Raster out(int(x1 - x0), int(y1 - y0), c);
  for (long long ty = y0 / T; ty * T < y1; ++ty)
    for (long long tx = x0 / T; tx * T < x1; ++tx) {
      const Tile tile = tiles.tile(image, level, int(tx), int(ty), draw, stop);
      const long long ax = std::max(x0, tx * T), bx = std::min(x1, tx * T + tile->width);
      const long long ay = std::max(y0, ty * T), by = std::min(y1, ty * T + tile->height);
      for (long long y = ay; y < by; ++y)
        std::memcpy(out.row(int(y - y0)) + (ax - x0) * c, tile->row(int(y - ty * T)) + (ax - tx * T) * c,
                    std::size_t(bx - ax) * c);
    }
  return out;
}

}  // namespace

RenderedTiles::RenderedTiles(std::size_t max_bytes)
    : max_bytes_(max_bytes), tiles_(max_bytes, [](const Tile& t) { return t->pixels.capacity() + kTileOverhead; }) {}

bool RenderedTiles::keeps(const Image& image, double scale) const {
  if (!(scale > 0)) return false;
  const tiles::Rect size = level_size(image, level_for(scale, level_count(image)));
  const double tiles_across = std::ceil(double(size.w) / kTileSize), tiles_down = std::ceil(double(size.h) / kTileSize);
  const double bytes = double(size.w) * double(size.h) * image.channels + tiles_across * tiles_down * kTileOverhead;
  return bytes <= double(max_bytes_) / 2;
}

tiles::Rect RenderedTiles::level_size(const Image& image, int level) {
  const double f = std::ldexp(1.0, -level);
  return {0, 0, std::max(1, covered_pixels(0, image.tw, f, INT_MAX).second + 1),
          std::max(1, covered_pixels(0, image.th, f, INT_MAX).second + 1)};
}

std::shared_ptr<const tiles::Raster> RenderedTiles::tile(const Image& image, int level, int tx, int ty, const DrawTile& draw,
                                                          const StopToken* stop) {
  const tiles::Rect size = level_size(image, level);
  const tiles::Rect r{tx * (long long)kTileSize, ty * (long long)kTileSize, 0, 0};
  if (tx < 0 || ty < 0 || r.x >= size.w || r.y >= size.h) throw std::out_of_range("tile outside the level");
  const tiles::Rect rect{r.x, r.y, std::min<long long>(kTileSize, size.w - r.x), std::min<long long>(kTileSize, size.h - r.y)};
  const std::string key = image.key + "|" + std::to_string(level) + "|" + std::to_string(tx) + "|" + std::to_string(ty);
  while (true) {
    check_stop(stop);
    bool drawing = false;
    try {
      return tiles_
          .get(
              key,
              [&] {
                drawing = true;
                tiles::Raster pixels = draw(level, rect);
                if (pixels.width != rect.w || pixels.height != rect.h || pixels.channels != image.channels)
                  throw std::logic_error("a drawn tile has the wrong size");
                return std::make_shared<const tiles::Raster>(std::move(pixels));
              },
              [&](const std::shared_future<Tile>& pending) { wait_for(pending, stop); })
          .value;
    } catch (const Stopped&) {
      if (drawing) throw;
      check_stop(stop);  // this request's own time ran out, or its client left, while waiting
      // The drawing request stopped, not this one: draw the tile here.
    }
  }
}

tiles::Raster RenderedTiles::view(const Image& image, const ZoomPlacement& place, int sw, int sh, const DrawTile& draw,
                                  const StopToken* stop) {
  tiles::Raster out(sw, sh, image.channels);
  const double s = place.scale;
  if (!(s > 0)) return out;
  const double view_x = -place.ox / s, view_y = -place.oy / s;
  const auto [x0, x1] = covered_pixels(view_x, image.tw, s, sw);
  const auto [y0, y1] = covered_pixels(view_y, image.th, s, sh);
  if (x1 < x0 || y1 < y0) return out;
  // The region path's choice (tiles::level_for_shrink): the coarsest level at least as fine as the screen.
  const int level = level_for(s, level_count(image));
  const tiles::Rect size = level_size(image, level);
  LevelPatch patch;
  patch.scale = std::ldexp(1.0, -level);
  // The level pixels the covered screen pixels sample, with one to spare on each side (read_patch's).
  patch.x0 = std::clamp<long long>((long long)std::floor((view_x + x0 / s) * patch.scale) - 1, 0, size.w - 1);
  patch.y0 = std::clamp<long long>((long long)std::floor((view_y + y0 / s) * patch.scale) - 1, 0, size.h - 1);
  const long long px1 = std::clamp<long long>((long long)std::ceil((view_x + (x1 + 1) / s) * patch.scale) + 1, patch.x0 + 1, size.w);
  const long long py1 = std::clamp<long long>((long long)std::ceil((view_y + (y1 + 1) / s) * patch.scale) + 1, patch.y0 + 1, size.h);
  patch.pixels = assemble(*this, image, level, patch.x0, patch.y0, px1, py1, draw, stop);
  draw_uniform(patch, view_x, view_y, s, {x0, y0, x1 - x0 + 1, y1 - y0 + 1}, out);
  return out;
}

}  // namespace zoomwarp::warp
