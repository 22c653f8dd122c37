// A whole-image warp's inverse sampled densely over the warped image, for views that show the
// warped image zoomed out uniformly (methods/retarget_zoom/: the warp is fixed per screen aspect,
// every view a uniform zoom into it). Zoomed out, a fine mesh's triangles cover a few screen
// pixels each and rasterising them one by one is the cost of a view; through the map a view is
// one cv::warpAffine of the map (screen pixel → source position, bilinear) and one cv::remap of
// one pyramid level.
//
// Thread safety: plain functions on plain data; an InverseMap is immutable once built.
#pragma once

#include <cstddef>
#include <vector>

#include "tiles/pyramid_reader.h"
#include "tiles/raster.h"
#include "tiles/store.h"
#include "warp/core/mesh.h"
#include "warp/core/stop_token.h"
#include "warp/core/uniform_zoom.h"

namespace zoomwarp::warp {

// Source positions on a cols × rows grid of nodes over a warped image [0, tw] × [0, th]: node
// (i, j) sits at warped position (i / per_x, j / per_y) — the first and last nodes on the image's
// edges, so a bilinear lookup anywhere in the image interpolates and never extrapolates — and
// holds the source position (image px) the warp's piecewise-linear inverse gives there,
// interleaved (u, v), row-major.
struct InverseMap {
  int cols = 0, rows = 0;
  double per_x = 1, per_y = 1;  // nodes per warped pixel: cols − 1 = tw·per_x, rows − 1 = th·per_y
  std::vector<float> uv;
  // The largest distance (warped px) between a point and where its bilinearly interpolated source
  // position lands through the warp, measured at every cell's centre: bilinear interpolation is
  // exact inside a triangle but cuts the corners where the warp's Jacobian jumps across an edge —
  // a strong warp's squeezed and stretched triangles side by side. A view at scale s sees it as
  // s·max_error screen px.
  double max_error = 0;
  // Per node, log2(1 / stretch), stretch = the warp's linear magnification there (warped/source,
  // sqrt of the area ratio), from central differences of uv — the triangle's own inside it: a
  // screen pixel at view scale s is drawn from level_for(s·stretch), as render_mesh draws its
  // triangle.
  std::vector<float> fineness;

  // The grid's bytes once built (the vectors' sizes are fixed by the grid).
  std::size_t bytes() const { return std::size_t(cols) * std::size_t(rows) * 3 * sizeof(float); }
};

// The grid (uv left empty) of a tw × th warped image with about max_nodes nodes, at most one per
// warped pixel: what a cache can weigh before the map is built.
InverseMap inverse_map_grid(double tw, double th, std::size_t max_nodes);

// The map of `warped` (a warp of `source` onto [0, tw] × [0, th], no folds) on
// inverse_map_grid(tw, th, max_nodes): the positions rasterise_inverse (render.h) writes, i.e. what
// render_mesh computes at a screen pixel centre there. A node no triangle covers (off the mesh by
// rounding: the mesh covers the warped image) takes the affine extension of the nearest
// triangle, as TriangleLocator answers a point just outside. max_error is measured by locating
// each cell's centre in the warped mesh (TriangleLocator). O(triangles + nodes); throws Stopped
// when `stop` says so.
InverseMap build_inverse_map(const Mesh& source, const std::vector<Point>& warped, double tw, double th,
                             std::size_t max_nodes, const StopToken* stop = nullptr);

// Whether a view at `scale` screen pixels per warped pixel may be drawn through a map on this grid:
// a screen pixel spans at least one node, so the map samples the warp no coarser than the screen
// does. Known before the map is built.
bool grid_serves(const InverseMap& grid, double scale);

// The map's positions are within this many screen pixels of the exact inverse's at the views it
// serves (a quarter pixel, with a margin for points between the cell centres it is measured at).
constexpr double kMaxMapError = 0.2;

// Whether a view at `scale` is drawn through the built `map`: grid_serves, and the map's error at
// that scale, scale·max_error, is at most kMaxMapError screen px.
bool map_serves(const InverseMap& map, double scale);

// The source positions of the screen pixels whose centres lie in the warped image as `place` puts
// it on a sw × sh screen (the rectangle x0, y0, width, height; empty if none): the map resampled
// bilinearly at the pixel centres by one cv::warpAffine, interleaved (u, v), row-major.
struct ScreenPositions {
  int x0 = 0, y0 = 0, width = 0, height = 0;
  std::vector<float> uv;
};
ScreenPositions screen_positions(const InverseMap& map, const ZoomPlacement& place, int sw, int sh);

// The view drawn through the map: screen_positions sampled bilinearly by cv::remap, each screen
// pixel from the pyramid level render_mesh would read its triangle from — level_for(scale·stretch)
// with the map's fineness resampled to the pixel — so that nothing is minified by more than 2×
// (one level for the whole screen, the typical one, would alias where the warp squeezes and blur
// where it stretches: on a strong warp the stretch varies by 2× and more within a screen). One
// remap when one level serves the whole screen (the usual case), else one per level under a mask.
// A level whose patch does not fit (patch_fits) is read from the next coarser one. Pixels outside
// the warped image are background (black, or transparent with alpha), as render_mesh leaves them.
// Throws std::runtime_error if the pyramid cannot be read, Stopped when `stop` says so.
tiles::Raster render_through_map(const InverseMap& map, const ZoomPlacement& place, int sw, int sh,
                                 const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                                 const StopToken* stop = nullptr);

}  // namespace zoomwarp::warp
