// Reading pyramid pixels for a screen: which level serves a magnification, and a patch of that
// level sampled bilinearly at source positions. render_view uses them per triangle; renderers
// that need no triangles (seam carving, methods/seam/) use them per screen pixel.
//
// Thread safety: plain functions; a LevelPatch is immutable once read.
#pragma once

#include <cstdint>
#include <utility>

#include "tiles/pyramid_reader.h"
#include "tiles/raster.h"
#include "tiles/store.h"

namespace zoomwarp::warp {

// The pyramid level for content shown at `magnification` screen pixels per source pixel: level k
// has 2^-k of the full resolution; the coarsest one with 2^-k ≥ magnification, so nothing is
// minified by more than 2× (no aliasing shimmer).
int level_for(double magnification, int levels);

// Along one axis of a screen showing an image at uniform `scale` from image position `origin` at
// the screen's edge: the first and last screen pixel whose centre lies in the image,
// (x + 0.5)/scale + origin ∈ [0, size], with a hair of tolerance as the triangles' edges have
// (first > last if none).
std::pair<int, int> covered_pixels(double origin, double size, double scale, int screen_size);

// Whether a patch of `level` covering source_width × source_height image pixels (with read_patch's
// spare pixels) is within the bounds a screen of sw × sh pixels may read: cv::remap reads
// positions in 16-bit fixed point, so a side beyond 32 767 px would be clamped to the wrong
// pixels (the bound is 16 384), and the patch's memory should follow the screen's (at most
// 4× its pixels + 1 Mpx). Each triangle's own patch is at most ~4× its screen area (its level
// minifies by less than 2× per axis), but a patch serving many triangles can be far larger when
// they lie far apart in the source (a strongly warped view); such a patch is read from a coarser
// level instead (a little softer, never wrong and never unbounded).
bool patch_fits(const tiles::Manifest& m, int level, double source_width, double source_height, int sw, int sh);

// Pixels of one pyramid level around a source rectangle, for bilinear sampling.
struct LevelPatch {
  tiles::Raster pixels;
  double scale = 1;          // level pixels per source pixel
  long long x0 = 0, y0 = 0;  // patch origin in level pixels

  // Bilinear sample at source position (u, v) into out[0 … channels); level pixel centres are at
  // integer + 0.5, positions beyond the patch take its border pixels.
  void sample(double u, double v, std::uint8_t* out) const;
};

// Draws an image shown at uniform `scale` (screen px per source px) from source position
// (view_x, view_y) at the screen's top-left corner into `pixels` of `screen` (covered_pixels'
// rectangle, inside the screen): each pixel centre sampled bilinearly from `patch` by one
// cv::warpAffine, beyond the patch its border replicated. When the patch position is a
// whole-pixel shift of the screen's (scale = patch.scale, integral origin) the pixels are copied
// exactly. The traditional zoom's renderer and retarget-zoom's tiles (rendered_tiles.h) draw
// through it.
void draw_uniform(const LevelPatch& patch, double view_x, double view_y, double scale, const tiles::Rect& pixels,
                  tiles::Raster& screen);

// The patch of `level` covering source rectangle [u0, u1] × [v0, v1] (clamped to the image) with
// one pixel to spare. Throws std::runtime_error if the pyramid cannot be read.
LevelPatch read_patch(const tiles::ImageEntry& image, tiles::PyramidReader& reader, int level, double u0, double v0,
                      double u1, double v1);

}  // namespace zoomwarp::warp
