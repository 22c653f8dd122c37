// A level-of-detail cut through the forest [ICAZ §5.3]: the set of nodes that currently form
// the mesh. It starts at the roots (the coarsest mesh) and is refined node by node; refining a
// node also refines the triangle across its longest edge — the dependent triangle — first
// splitting that one as often as needed until it shares the edge as its own longest edge
// (Rivara's longest-edge refinement), so the cut is always conforming: no T-junctions.
//
// Not thread-safe: a cut is one view's working state. Several cuts may read one forest at once
// if none of them may grow it (set_growable(false)); a cut that may grow the forest needs it to
// itself.
#pragma once

#include <vector>

#include "warp/icaz/edge_map.h"
#include "warp/icaz/forest.h"

namespace zoomwarp::warp {

class LodCut {
 public:
  // A cut at the roots of `forest`, which it may grow (children made on first use).
  explicit LodCut(Forest& forest);

  // Whether refining may make forest nodes that do not exist yet. When not, refining a node the
  // forest has not split throws ForestGrowthNeeded and leaves the cut half refined (discard it):
  // a cut that only reads the forest can share it with other readers.
  void set_growable(bool growable) { growable_ = growable ? &forest_ : nullptr; }

  bool active(int node) const { return node < int(active_.size()) && active_[node]; }

  // Splits an active node, and whatever keeps the cut conforming. Appends every node split
  // (including dependents) to `split` if given.
  void refine(int node, std::vector<int>* split = nullptr);

  // The active nodes, in no particular order.
  std::vector<int> nodes() const;

  // The cut as a mesh with its own compact vertex numbering; forest_vertex[i] is the forest
  // vertex of mesh vertex i.
  Mesh mesh(std::vector<int>* forest_vertex = nullptr, std::vector<int>* node_of_triangle = nullptr) const;

 private:
  void activate(int node);
  void split(int node);  // an active node by its children (refine() keeps the cut conforming)
  int across(int node, int a, int b) const;  // the other active node on edge (a, b), or -1

  std::array<int, 2> children(int node);

  Forest& forest_;
  Forest* growable_;  // forest_ when the cut may grow it, else null
  std::vector<char> active_;
  std::vector<int> list_;  // active nodes, possibly with stale entries (checked against active_)
  EdgeMap edges_;  // edge -> up to two active nodes
};

}  // namespace zoomwarp::warp
