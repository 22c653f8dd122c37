#include "warp/icaz/lod_cut.h"

#include <stdexcept>

namespace zoomwarp::warp {

LodCut::LodCut(Forest& forest) : forest_(forest), growable_(&forest) {
  for (int r = 0; r < forest.root_count(); ++r) activate(r);
}

std::array<int, 2> LodCut::children(int node) {
  if (growable_) return growable_->children(node);
  if (!forest_.is_split(node)) throw ForestGrowthNeeded();
  return forest_.existing_children(node);
}

void LodCut::activate(int node) {
  if (node >= int(active_.size())) active_.resize(std::size_t(node) + 1, 0);
  active_[node] = 1;
  list_.push_back(node);
  const Triangle& t = forest_.corners(node);
  for (int k = 0; k < 3; ++k) {
    auto [nodes, fresh] = edges_.emplace(edge_key(t[k], t[(k + 1) % 3]), {node, -1});
    if (!fresh) (*nodes)[1] = node;
  }
}

// Replaces an active node (a, b, c) — (a, b) its longest edge — by its children (a, m, c) and
// (m, b, c): the edges (c, a) and (b, c) keep their other node and take the child now on them,
// (a, b) loses the node and (a, m), (m, b) gain a child each, and (m, c) is new. Seven updates of
// the edge map instead of taking the node's three edges out and putting the children's six in.
void LodCut::split(int node) {
  const Triangle t = forest_.corners(node);
  const auto [first, second] = children(node);
  int m = -1;
  for (int v : forest_.corners(first))
    if (v != t[0] && v != t[2]) m = v;
  active_[node] = 0;
  for (int c : {first, second}) {
    if (c >= int(active_.size())) active_.resize(std::size_t(c) + 1, 0);
    active_[c] = 1;
    list_.push_back(c);
  }
  auto replace = [&](std::uint64_t key, int by) {
    auto& pair = *edges_.find(key);
    (pair[0] == node ? pair[0] : pair[1]) = by;
  };
  replace(edge_key(t[2], t[0]), first);
  replace(edge_key(t[1], t[2]), second);
  const std::uint64_t halved = edge_key(t[0], t[1]);
  auto& pair = *edges_.find(halved);
  if (pair[0] == node) pair[0] = pair[1];
  pair[1] = -1;
  if (pair[0] < 0) edges_.erase(halved);
  for (auto [key, c] : {std::pair{edge_key(t[0], m), first}, std::pair{edge_key(m, t[1]), second}}) {
    auto [nodes, fresh] = edges_.emplace(key, {c, -1});
    if (!fresh) (*nodes)[1] = c;
  }
  edges_.emplace(edge_key(m, t[2]), {first, second});
}

int LodCut::across(int node, int a, int b) const {
  const auto* pair = edges_.find(edge_key(a, b));
  if (!pair) return -1;
  return (*pair)[0] == node ? (*pair)[1] : (*pair)[0];
}

void LodCut::refine(int node, std::vector<int>* split) {
  if (!active(node)) return;
  const Triangle t = forest_.corners(node);
  // Make the neighbour across our longest edge share it as its own longest edge.
  for (int guard = 0;; ++guard) {
    if (guard > 64) throw std::logic_error("longest-edge refinement did not terminate");
    const int g = across(node, t[0], t[1]);
    if (g < 0) break;  // image boundary
    const Triangle& gt = forest_.corners(g);
    if (edge_key(gt[0], gt[1]) == edge_key(t[0], t[1])) {  // compatible: split both together
      this->split(g);
      if (split) split->push_back(g);
      break;
    }
    refine(g, split);  // its longest edge is longer than ours: split it first, then look again
  }
  if (!active(node)) return;
  this->split(node);
  if (split) split->push_back(node);
}

std::vector<int> LodCut::nodes() const {
  std::vector<int> out;
  std::vector<char> seen(active_.size(), 0);
  for (int n : list_)
    if (active_[n] && !seen[n]) seen[n] = 1, out.push_back(n);
  return out;
}

Mesh LodCut::mesh(std::vector<int>* forest_vertex, std::vector<int>* node_of_triangle) const {
  Mesh m;
  const std::vector<int> active = nodes();
  FlatMap<int> local;  // forest vertex → mesh vertex
  // A triangulated disc has (triangles + boundary vertices) / 2 + 1 vertices: room for a
  // boundary of up to a quarter of the triangles.
  const std::size_t vertices = active.size() * 5 / 8 + 64;
  local.reserve(vertices);
  std::vector<int> ids;
  ids.reserve(vertices);
  m.vertices.reserve(ids.capacity()), m.triangles.reserve(active.size());
  if (node_of_triangle) node_of_triangle->reserve(node_of_triangle->size() + active.size());
  for (int n : active) {
    Triangle t;
    for (int k = 0; k < 3; ++k) {
      const int v = forest_.corners(n)[k];
      auto [index, fresh] = local.emplace(std::uint32_t(v), int(ids.size()));
      if (fresh) {
        ids.push_back(v);
        m.vertices.push_back(forest_.vertices()[v]);
      }
      t[k] = *index;
    }
    m.triangles.push_back(t);
    if (node_of_triangle) node_of_triangle->push_back(n);
  }
  if (forest_vertex) *forest_vertex = std::move(ids);
  return m;
}

}  // namespace zoomwarp::warp
