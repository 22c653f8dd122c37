// method=patch's precomputation [Lin13] (patch_energy.h): MethodInput → PatchModel, stored as
// patch.<saliency>.bin. On the analysis image: the patches (patch_segmentation.h), their
// significance from the selected saliency map (faces and curator edits painted in), the quad
// grid, and the two solves V_W, V_H from which every target size follows by one axpy. Lines: the
// curator's and the suggested ones the curator kept (method_lines.h).
//
// Thread safety: pure functions.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "warp/core/mesh.h"
#include "warp/methods/patch/patch_energy.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

struct PatchModel {
  PatchGrid grid;                            // analysis px
  std::vector<Point> per_width, per_height;  // V_W, V_H per grid vertex
};

struct PatchPrecomputeOptions {
  SegmentationOptions segmentation;
  PatchEnergyOptions energy;
};

PatchModel build_patch_model(const MethodInput& input, const PatchPrecomputeOptions& options = {});

// patch.<saliency>.bin's payload and back (parse throws std::runtime_error for malformed bytes).
std::string patch_model_bytes(const PatchModel& model);
PatchModel parse_patch_model(std::string_view bytes);

// The grid as a triangle mesh of the analysis image: two CCW triangles per quad, split along
// the (top-left, bottom-right) diagonal; vertex v is grid vertex v.
Mesh patch_mesh(const PatchGrid& grid);

// The grid's positions for a target of target_w × target_h analysis px: W'·V_W + H'·V_H.
std::vector<Point> patch_positions(const PatchModel& model, double target_w, double target_h);

}  // namespace zoomwarp::warp
