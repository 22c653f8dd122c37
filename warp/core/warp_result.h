// What a mesh warp returns: the warped positions and how the solve went. Plain data, shared by the
// solvers of every method (ShapeWarp's local–global iteration, the other methods' solves) and
// carried in a View as its statistics.
#pragma once

#include <vector>

#include "warp/core/mesh.h"

namespace zoomwarp::warp {

struct WarpResult {
  std::vector<Point> positions;  // v' for every mesh vertex
  int iterations = 0;
  bool converged = false;
  int guard_rounds = 0;  // rounds of the fold-over guard that were needed
  double affine_blend = 0;  // how far the result was blended towards the affine stretch (0: not)
  int inverted = 0;         // triangles still inverted at the end (0 with the fold-over guard on)
};

}  // namespace zoomwarp::warp
