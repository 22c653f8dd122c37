// A point of a mesh written in the corners of the triangle that holds it — the piecewise-affine
// map of a warp at that point: Q(p) = Σ_k weights[k]·Q_{vertices[k]}. A mesh vertex i itself is
// {i, i, i}, {1, 0, 0}. What a line held through its triangles is made of (ShapeWarp's line term,
// mp's line points; issue 30). Plain data; thread-safe.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "warp/core/mesh.h"

namespace zoomwarp::warp {

struct CornerPoint {
  std::array<int, 3> vertices{};
  std::array<double, 3> weights{};
};

// Whether p is a mesh vertex (its first corner, weight 1).
inline bool is_vertex(const CornerPoint& p) { return p.weights[0] == 1 && p.weights[1] == 0 && p.weights[2] == 0; }

// Where p lands for the vertex positions q.
inline Point position(const CornerPoint& p, const std::vector<Point>& q) {
  Point r;
  for (int k = 0; k < 3; ++k) {
    r.x += p.weights[k] * q[std::size_t(p.vertices[k])].x;
    r.y += p.weights[k] * q[std::size_t(p.vertices[k])].y;
  }
  return r;
}

}  // namespace zoomwarp::warp
