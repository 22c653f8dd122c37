// The coarsest mesh of an image [ICAZ §4.1]: a conforming Delaunay triangulation of the image
// rectangle with the constrained lines inserted as edges, refined until every triangle is under a
// maximum area and above a minimum angle. Unlike the paper, its size is also bounded by a vertex
// budget, so that a gigapixel image still gets a coarsest mesh the solver handles in milliseconds
// (the open problem of §7): the area bound grows until the budget holds.
#pragma once

#include <vector>

#include "warp/core/mesh.h"

namespace zoomwarp::warp {

struct CoarseMeshOptions {
  double max_triangle_area = 10000;  // px², the paper's setting [ICAZ §6.1]
  double min_angle_degrees = 20;     // ≤ 20.7° guarantees termination of Delaunay refinement
  int vertex_budget = 2000;
};

struct CoarseMesh {
  Mesh mesh;
  // For each input line, the mesh vertices on it, ordered from its start to its end.
  std::vector<std::vector<int>> line_vertices;
  double max_triangle_area = 0;  // the area bound that was finally used
};

// Triangulates [0, width] × [0, height]. Lines are clipped to the rectangle; lines shorter than a
// pixel after clipping are ignored (their line_vertices entry is empty). Throws
// std::invalid_argument for lines whose crossings CGAL's refinement cannot mesh (seen with 64
// lines crossing on a grid).
CoarseMesh build_coarse_mesh(double width, double height, const std::vector<Segment>& lines,
                             const CoarseMeshOptions& options = {});

}  // namespace zoomwarp::warp
