// Rendering a view [ICAZ §5] (the warped image seen through the screen): every visible warped
// triangle is texture-mapped from the pyramid level that fits its own on-screen scale — the
// coarsest level whose resolution is still at least the screen's there, so a triangle is never
// minified by more than 2× and shows no aliasing shimmer — with bilinear filtering. At zoom 1
// (scale 1, integral view origin) every screen pixel is exactly a pixel of the original.
#pragma once

#include <cstdint>
#include <vector>

#include "tiles/pyramid_reader.h"
#include "warp/core/stop_token.h"
#include "warp/core/view.h"

namespace zoomwarp::warp {

// The screen (screen_width × screen_height, the image's channels). Screen pixels that no
// triangle covers (letterboxing of the traditional baseline) are black, or transparent for
// images with alpha. Throws std::runtime_error if the pyramid cannot be read, and Stopped when
// `stop` says so (checked between triangles).
tiles::Raster render_view(const View& view, int screen_width, int screen_height, const tiles::ImageEntry& image,
                          tiles::PyramidReader& reader, const StopToken* stop = nullptr);

// render_view of a non-uniform view given by its parts: `source` (image pixels), its vertices'
// `screen` positions and the `visible` triangles — for a method that keeps its mesh and need not
// copy it into a View per request (methods/retarget_zoom/).
tiles::Raster render_mesh(const Mesh& source, const std::vector<Point>& screen, const std::vector<int>& visible,
                          int screen_width, int screen_height, const tiles::ImageEntry& image,
                          tiles::PyramidReader& reader, const StopToken* stop = nullptr);

// The piecewise-linear inverse of a warp sampled on a grid, as render_mesh samples it per screen
// pixel (the same rasterisation, positions and edge rule), for a method that caches it per warp
// (methods/retarget_zoom/): per pixel (x, y) of a cols × rows grid, whose centre is
// (x + 0.5, y + 0.5) in the coordinates of `grid` (the vertices of `source` placed on the grid),
// the source position (image px) of that centre through the triangle covering it is written to
// u[y·cols + x] and v[y·cols + x], and covered[y·cols + x] = 1. A centre on an edge shared by two
// triangles takes the later one's (the same point up to rounding). Pixels no triangle covers are
// left untouched: callers initialise them. Triangles of zero area on the grid are skipped.
// Throws Stopped when `stop` says so (checked between triangles).
void rasterise_inverse(const Mesh& source, const std::vector<Point>& grid, int cols, int rows, float* u, float* v,
                       std::uint8_t* covered, const StopToken* stop = nullptr);

}  // namespace zoomwarp::warp
