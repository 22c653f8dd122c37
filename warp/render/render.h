// Rendering a view [ICAZ §5] (the warped image seen through the screen): every visible warped
// triangle is texture-mapped from the pyramid level that fits its own on-screen scale — the
// coarsest level whose resolution is still at least the screen's there, so a triangle is never
// minified by more than 2× and shows no aliasing shimmer — with bilinear filtering. At zoom 1
// (scale 1, integral view origin) every screen pixel is exactly a pixel of the original.
#pragma once

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
// copy it into a View per request (methods/retarget_zoom/: each tile of its retargeted image).
tiles::Raster render_mesh(const Mesh& source, const std::vector<Point>& screen, const std::vector<int>& visible,
                          int screen_width, int screen_height, const tiles::ImageEntry& image,
                          tiles::PyramidReader& reader, const StopToken* stop = nullptr);

}  // namespace zoomwarp::warp
