// locate_in (uniform_zoom.h) for many points of one mesh: a uniform grid over the mesh's bounding
// box lists, per cell, the triangles whose bounding box — widened by a rounding margin — meets
// the cell, in mesh order. A point is looked up among its cell's triangles; only a point off the
// mesh has all of them scanned as locate_in does. The triangle locate_in returns for a point on
// the mesh is the first in mesh order whose barycentric coordinates are all ≥ 0 as computed (or,
// for a point on an edge where rounding makes them all a hair negative, the first of the
// nearest to that): such triangles' widened boxes hold the point, and a triangle whose widened
// box misses it has a coordinate clearly below 0 (unless it is a sliver of aspect ~10⁶), so the
// answers are locate_in's, bit for bit. Geomorphing places every vertex a view lacks this way
// (O(V·T) with locate_in); most of those lie on an edge of the view's mesh.
//
// Immutable once built; find() is const and thread-safe. Keeps a reference to the mesh, which
// must outlive it.
#pragma once

#include <cstddef>
#include <vector>

#include "warp/core/mesh.h"
#include "warp/core/uniform_zoom.h"

namespace zoomwarp::warp {

class TriangleLocator {
 public:
  // O(triangles + cells); about one cell per four triangles.
  explicit TriangleLocator(const Mesh& mesh);

  // locate_in(mesh, p).
  MeshPoint find(const Point& p) const;

  // Bytes held by the grid (not the mesh it refers to).
  std::size_t memory_bytes() const { return (start_.capacity() + triangles_.capacity()) * sizeof(int); }

 private:
  int cell_x(double x) const;
  int cell_y(double y) const;

  const Mesh& mesh_;
  double x0_ = 0, y0_ = 0, cell_w_ = 1, cell_h_ = 1, per_cell_w_ = 1, per_cell_h_ = 1;
  int nx_ = 0, ny_ = 0;
  std::vector<int> start_;      // per cell (row-major), into triangles_; one past the end last
  std::vector<int> triangles_;  // ascending within a cell
};

}  // namespace zoomwarp::warp
