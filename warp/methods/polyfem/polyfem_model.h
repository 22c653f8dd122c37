// method=polyfem's precomputation [PolyFEM], per image version and saliency kind
// (polyfem.<saliency>.bin): the saliency-adaptive polygon mesh of the analysis image
// (meshing/cvt_mesh.h), the global system with the line term of the curator's and the kept
// detected lines (method_lines.h, polyfem_lines.h) and its two decoupled solves g_x, g_y
// (polyfem_system.h), the aspect range on which their axpy folds nowhere, per cell δ_c, G's chord
// deviation at export levels 0–3 (polyfem_export.h), and K, L_x, L_y for the fallback
// (polyfem_fallback.h).
//
// Thread safety: pure functions.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "warp/meshing/polygon_mesh.h"
#include "warp/methods/polyfem/polyfem_system.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

struct PolyfemModel {
  static constexpr int kChordLevels = 4;  // δ_c stored for levels 0–3
  PolyfemSolution solution;               // nodes (rebuilt from the mesh on parse), g_x, g_y, K, L_x, L_y
  PolygonMesh mesh;                       // analysis px
  AspectRange fold_free;                  // of the axpy
  std::vector<std::array<Point, kChordLevels>> chord;  // δ_c of G per cell and level
};

PolyfemModel build_polyfem_model(const MethodInput& input, const PolyfemOptions& options = {});
std::string polyfem_model_bytes(const PolyfemModel& model);
PolyfemModel parse_polyfem_model(std::string_view bytes);  // throws std::runtime_error

}  // namespace zoomwarp::warp
