// The multi-resolution forest [ICAZ §5.3]: one tree per triangle of the coarsest mesh; a
// node's two children come from splitting its longest edge at the midpoint. Stored as flat
// arrays. At ingest the forest is built level by level down to the smallest triangles a view
// asks for at 100 % (build_levels), within a node budget, and serialised with the image. Deeper
// nodes — a gigapixel image's full forest would be millions — are made on first request (the
// split of a node is always the same), and can be forgotten again to cap memory.
//
// Corners of every node are stored rotated so that (corners[0], corners[1]) is its longest edge;
// ties are broken by vertex ids, so two triangles sharing an edge agree on it. Orientation is kept
// (signed_area2 > 0).
#pragma once

#include <array>
#include <cstdint>
#include <exception>
#include <iosfwd>
#include <unordered_map>
#include <vector>

#include "warp/core/mesh.h"

namespace zoomwarp::warp {

// A view needed a forest node that has not been made yet (thrown by a cut that may not grow
// the forest; see LodCut::set_growable).
struct ForestGrowthNeeded : std::exception {
  const char* what() const noexcept override { return "the forest must grow"; }
};

// Not thread-safe for writers: children() may make nodes (moving the arrays), as may
// build_levels() and forget_lazy_nodes(). Const members may be called from several threads at
// once while no thread calls a non-const one (Icaz holds a shared_mutex for that).
class Forest {
 public:
  Forest() = default;
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
  // The children of a split node ({-1, -1} if it is not split); never grows the forest.
  std::array<int, 2> existing_children(int node) const { return children_[node]; }
  bool is_split(int node) const { return children_[node][0] >= 0; }

  // Splits every leaf larger than `min_area` (source px²), level by level, but stops before a
  // level that would take the forest past `max_nodes`. Then keeps what exists (see below).
  void build_levels(double min_area, int max_nodes);

  // The kept nodes (the roots, or what build_levels or read made) are never forgotten;
  // forget_lazy_nodes() drops every node and vertex made after them, ids below stay valid.
  int kept_nodes() const { return kept_nodes_; }
  void forget_lazy_nodes();

  // Bytes held (an estimate of the arrays and the midpoint map).
  std::size_t memory_bytes() const;

  // Serialisation of the kept nodes: the split nodes in the order they were split — children,
  // corners and midpoints follow from it — so 4 bytes per two nodes. read() replays the splits
  // on the forest of `coarsest` and throws std::runtime_error on damaged input.
  void write(std::ostream& out) const;
  static Forest read(std::istream& in, const Mesh& coarsest);

 private:
  int add_node(Triangle t, int root, int parent);
  int midpoint(int a, int b, int root);

  void keep_current();

  int roots_ = 0;
  int kept_nodes_ = 0, kept_vertices_ = 0;
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
