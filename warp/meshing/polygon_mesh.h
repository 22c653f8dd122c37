// A mesh of convex polygonal cells tiling a rectangle, as plain data: what method=polyfem's
// finite elements live on [PolyFEM §3, §4.3]. Vertices in analysis pixels (y down); each cell
// lists its vertices counter-clockwise in mesh.h's sense (positive signed area, y down), with no
// three consecutive vertices collinear; neighbouring cells share whole edges (a vertex on a
// neighbour's edge is a vertex of that neighbour too), so the edges are conforming.
#pragma once

#include <vector>

#include "warp/core/mesh.h"

namespace zoomwarp::warp {

struct PolygonMesh {
  double width = 0, height = 0;
  std::vector<Point> vertices;
  std::vector<std::vector<int>> cells;
};

}  // namespace zoomwarp::warp
