// The /mesh body as api/mesh_json.cc built it before issue 16: an nlohmann::json tree, dumped.
// Kept as the oracle the streaming writer is checked against (unit/mesh_json_test.cc) and
// measured against (bench/mesh_json_bench.cc); not used by the server.
#pragma once

#include <string>

#include "api/deepzoom.h"
#include "api/view_query.h"
#include "tiles/manifest.h"
#include "warp/core/view.h"

namespace zoomwarp::testing {

// Same contract as api::mesh_json, except that a position that is not finite is written as null.
std::string reference_mesh_json(const tiles::Manifest& image, const api::ViewQuery& query, const warp::View& view,
                                const warp::Geomorph* morph, const api::DziLayout& dzi,
                                const std::string& tile_extension);

}  // namespace zoomwarp::testing
