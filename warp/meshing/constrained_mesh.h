// A constrained Delaunay triangulation of given points inside the image rectangle [Guo09 §3.2]:
// the points become mesh vertices, the given constraints (pairs of point indices) become mesh
// edges, and the rectangle's border is constrained through the points lying on it. Then Delaunay
// refinement towards a minimum angle (ours: [Guo09 §3.2] triangulates the points as they are,
// whose slivers make a Newton solve on edge lengths ill-conditioned), stopped at a vertex budget.
//
// Plain data in and out, so that CGAL stays in this folder's .cc files.
//
// Thread safety: a pure function, safe to call concurrently.
#pragma once

#include <array>
#include <vector>

#include "warp/core/mesh.h"

namespace zoomwarp::warp {

struct ConstrainedMeshOptions {
  double min_angle_degrees = 20;  // ≤ 20.7° guarantees that unbounded refinement terminates
  // Refinement inserts vertices only while the mesh has fewer than this many; the input points
  // and missing corners are always kept, so the result may exceed a budget they already exceed.
  int vertex_budget = 390;
};

// Triangulates [0, width] × [0, height] through `points`, with `constraints` as edges.
//
// Output: mesh.vertices[i] == points[i] for every input point, in input order; then the corners
// that were not among the points; then the vertices refinement inserted (midpoints of
// constrained edges, which stay on their segment, and circumcentres). Triangles are
// counter-clockwise in mesh.h's sense (signed_area2 > 0) and tile the rectangle; every vertex on
// the border lies exactly on it. Refinement splits the worst triangles first and stops at the
// budget, so the angle bound holds everywhere only when the budget was not reached (and, as
// always for Delaunay refinement, not inside angles the constraints themselves make smaller).
//
// Throws std::invalid_argument — before any meshing — for a non-positive or non-finite size, a
// point outside the rectangle or not finite, two equal points, a constraint naming a point that
// does not exist or the same point twice, two constraints that cross or overlap or where one
// touches the other away from a shared end, and a constraint along the border. Also for input
// CGAL's refinement cannot mesh (its checks stay on here, so that it throws instead of crashing).
Mesh build_constrained_mesh(double width, double height, const std::vector<Point>& points,
                            const std::vector<std::array<int, 2>>& constraints,
                            const ConstrainedMeshOptions& options = {});

}  // namespace zoomwarp::warp
