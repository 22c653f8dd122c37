// The multi-resolution forest of seed 000 §5.3: one tree per triangle of the coarsest mesh; a
// node's two children come from splitting its longest edge at the midpoint. Stored as flat
// arrays. Nodes are made on first request — the split of a node is always the same — so memory
// follows what the views have visited rather than the image size (a gigapixel image's full
// forest down to 250 px² would be millions of nodes).
//
// Corners of every node are stored rotated so that (corners[0], corners[1]) is its longest edge;
// ties are broken by vertex ids, so two triangles sharing an edge agree on it. Orientation is kept
// (signed_area2 > 0).
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "warp/mesh.h"

namespace zoomwarp::warp {

class Forest {
 public:
  explicit Forest(const Mesh& coarsest);

  int root_count() const { return roots_; }
  int node_count() const { return int(corners_.size()); }
  const std::vector<Point>& vertices() const { return vertices_; }

  const Triangle& corners(int node) const { return corners_[node]; }
  int root_of(int node) const { return root_[node]; }
  int parent(int node) const { return parent_[node]; }  // -1 for roots
  // The root whose affine map places vertex v (the triangle it was created in).
  int root_of_vertex(int v) const { return vertex_root_[v]; }
  double area(int node) const;  // in source pixels²

  // The two children (made now if they do not exist yet).
  std::array<int, 2> children(int node);

 private:
  int add_node(Triangle t, int root, int parent);
  int midpoint(int a, int b, int root);

  int roots_ = 0;
  std::vector<Point> vertices_;
  std::vector<int> vertex_root_;
  std::vector<Triangle> corners_;
  std::vector<std::array<int, 2>> children_;  // {-1, -1} until split
  std::vector<int> root_, parent_;
  std::unordered_map<std::uint64_t, int> midpoints_;  // edge (min, max vertex) -> midpoint vertex
};

// Key of the undirected edge (a, b).
inline std::uint64_t edge_key(int a, int b) {
  return a < b ? (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b)
               : (std::uint64_t(std::uint32_t(b)) << 32) | std::uint32_t(a);
}

}  // namespace zoomwarp::warp
