// The body of GET /v1/images/{id}/mesh (api/openapi.json, "Mesh"): what a thin client needs to
// draw a view itself — the visible triangles of the deformed mesh with, per vertex, its source
// position in full-resolution pixels (u, v) and its screen position (x, y), optionally the
// geomorph pair (where each vertex was in the previous view), and the Deep Zoom tiles at the
// level that matches the on-screen scale.
#pragma once

#include <string>

#include "api/deepzoom.h"
#include "api/view_query.h"
#include "tiles/manifest.h"
#include "warp/core/view.h"

namespace zoomwarp::api {

// Without `morph` the triangles listed are `view.visible`, as every engine fills it. `morph`, when
// given (from_* parameters), is the common refinement of the previous view and `view`: its
// triangles touching the screen in either view are listed, its vertices with `to` as (x, y) and
// `from` in the parallel "from" array; `view` then gives only the view's geometry.
// `tile_extension` is that of the image's DZI tiles ("jpg", or "png" with alpha).
// Positions are rounded to a thousandth of a pixel. The text is written straight into the
// returned string (one allocation of the body), the same document the nlohmann tree of earlier
// versions dumped (tests/unit/mesh_json_test.cc). A position that is not a finite number cannot
// be written as JSON: throws std::runtime_error (a generic 500, the detail in the server's log).
// Thread-safe: reads its arguments only.
std::string mesh_json(const tiles::Manifest& image, const ViewQuery& query, const warp::View& view,
                      const warp::Geomorph* morph, const DziLayout& dzi, const std::string& tile_extension);

}  // namespace zoomwarp::api
