// A level-of-detail cut through the forest (seed 000 §5.3): the set of nodes that currently form
// the mesh. It starts at the roots (the coarsest mesh) and is refined node by node; refining a
// node also refines the triangle across its longest edge — the dependent triangle — first
// splitting that one as often as needed until it shares the edge as its own longest edge
// (Rivara's longest-edge refinement), so the cut is always conforming: no T-junctions.
#pragma once

#include <vector>

#include "warp/edge_map.h"
#include "warp/forest.h"

namespace zoomwarp::warp {

class LodCut {
 public:
  explicit LodCut(Forest& forest);

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
  void deactivate(int node);
  int across(int node, int a, int b) const;  // the other active node on edge (a, b), or -1

  Forest& forest_;
  std::vector<char> active_;
  std::vector<int> list_;  // active nodes, possibly with stale entries (checked against active_)
  EdgeMap edges_;  // edge -> up to two active nodes
};

}  // namespace zoomwarp::warp
