// The lines a mesh method keeps straight (issue 30): the curator's (ImageModel::lines) and the
// suggestions the curator kept (MethodInput::detected_lines), both in image pixels, brought to
// the analysis image the precomputations work on.
//
// Thread safety: a pure function.
#pragma once

#include <vector>

#include "warp/core/mesh.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

// The curator's lines, then the detected ones (longest first), in analysis pixels (scaled per
// axis from the image's size to the analysis image's), clipped to the analysis image; lines
// wholly outside it are left out.
std::vector<Segment> method_lines(const MethodInput& input);

}  // namespace zoomwarp::warp
