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
#include "warp/icaz/icaz.h"

namespace zoomwarp::api {

// `morph`, when given (from_* parameters), is the common refinement of the previous view and
// `view`: its vertices are listed with `to` as (x, y) and `from` in the parallel "from" array.
// `tile_extension` is that of the image's DZI tiles ("jpg", or "png" with alpha).
std::string mesh_json(const tiles::Manifest& image, const ViewQuery& query, const warp::View& view,
                      const warp::Geomorph* morph, const DziLayout& dzi, const std::string& tile_extension);

}  // namespace zoomwarp::api
