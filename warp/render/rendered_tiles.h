// An image that is not stored but drawn on demand — a warp of the stored image onto a tw × th
// rectangle (retarget-zoom's retargeted image, methods/retarget_zoom/) — seen as a tile pyramid
// whose tiles are drawn on first use and kept: a uniform view into it (traditional zoom) then costs
// what a region of a stored pyramid costs (api's IIIF regions, tiles/pyramid_reader.h) — the
// level at most 2× finer than the screen, its covering tiles assembled into one patch, one
// resampling onto the screen — instead of drawing the warp's tens of thousands of triangles per
// view.
//
// Level k is the image at 2^-k of its size: the pixels whose centres lie in the image,
// ⌊w·2^-k + ½⌋ × ⌊h·2^-k + ½⌋ (covered_pixels) — none of them background, so sampling near the
// image's edge never blends the background in; tiles of kTileSize² pixels (smaller at the right
// and bottom edges). The resampling is draw_uniform (level_patch.h), bilinear at the view's exact
// scale and sub-pixel origin — what the traditional zoom's renderer does from the stored pyramid
// (a pixel-snapped cv::resize as the region path does would misplace the picture by up to half a
// level pixel); at scale 1 with an integral origin it copies level 0's pixels exactly. Pixels
// outside the image stay background (black, or transparent with alpha), as render_mesh leaves
// them.
//
// Tiles are kept in a single-flight LRU (tiles/single_flight.h) bounded in bytes: two views needing
// one tile draw it once. A tile's key is the caller's image key (which must name everything that
// changes its pixels: the image version, the warp) and its level and position.
//
// Thread safety: every member may be called concurrently; bytes() takes no lock.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>

#include "tiles/raster.h"
#include "tiles/single_flight.h"
#include "warp/core/stop_token.h"
#include "warp/core/uniform_zoom.h"

namespace zoomwarp::warp {

class RenderedTiles {
 public:
  static constexpr int kTileSize = 256;

  // The pixels of rectangle `r` (level pixels, inside the level) of level `level`: r.w × r.h. It
  // may throw (Stopped, std::runtime_error); nothing is kept then.
  using DrawTile = std::function<tiles::Raster(int level, const tiles::Rect& r)>;

  // The image: `key` names its pixels, tw × th its size (level-0 pixels, fractional allowed).
  struct Image {
    std::string key;
    double tw = 0, th = 0;
    int channels = 3;
  };

  explicit RenderedTiles(std::size_t max_bytes);

  // The sw × sh screen showing `image` as `place` puts it (scale, offset; the image at any scale).
  // Tiles missing are drawn by `draw` (with this request's `stop`); a tile another request is
  // drawing is waited for, up to `stop`, and drawn here if that request stops. Throws what `draw`
  // throws, and Stopped when `stop` says so.
  tiles::Raster view(const Image& image, const ZoomPlacement& place, int sw, int sh, const DrawTile& draw,
                     const StopToken* stop = nullptr);

  // Tile (tx, ty) of `level`: from the cache or drawn now, as view() gets it.
  std::shared_ptr<const tiles::Raster> tile(const Image& image, int level, int tx, int ty, const DrawTile& draw,
                                            const StopToken* stop = nullptr);

  // Level `level`'s size in pixels: those whose centres lie in the image.
  static tiles::Rect level_size(const Image& image, int level);

  // Whether the level views at `scale` read is small enough to keep: all its tiles in half the
  // cache. Views of a larger level keep few of the tiles they draw (random views over a 127 MP
  // image's level 0, ~290 MB, found one in five in a 64 MB cache) and draw ~3× their own pixels
  // each (whole tiles around a screen), several times a direct drawing's cost: the caller draws
  // those directly.
  bool keeps(const Image& image, double scale) const;

  // The kept tiles' bytes (pixels and bookkeeping). Lock-free.
  std::size_t bytes() const { return tiles_.weight(); }

 private:
  const std::size_t max_bytes_;
  tiles::SingleFlight<std::shared_ptr<const tiles::Raster>> tiles_;
};

}  // namespace zoomwarp::warp
