#include "warp/icaz/forest.h"

#include <cmath>
#include <istream>
#include <ostream>
#include <stdexcept>

namespace zoomwarp::warp {

namespace {
double length2(const Point& a, const Point& b) { return (a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y); }
}  // namespace

Forest::Forest(const Mesh& coarsest) : vertices_(coarsest.vertices), vertex_root_(coarsest.vertices.size(), 0) {
  roots_ = int(coarsest.triangles.size());
  for (int f = 0; f < roots_; ++f) {
    for (int v : coarsest.triangles[f]) vertex_root_[v] = f;
    add_node(coarsest.triangles[f], f, -1);
  }
  keep_current();
}

void Forest::keep_current() {
  kept_nodes_ = node_count();
  kept_vertices_ = int(vertices_.size());
}

void Forest::build_levels(double min_area, int max_nodes) {
  std::vector<int> level;
  for (int n = 0; n < node_count(); ++n)
    if (!is_split(n)) level.push_back(n);
  for (;;) {
    std::vector<int> split;
    for (int n : level)
      if (area(n) > min_area) split.push_back(n);
    if (split.empty() || node_count() + 2 * std::int64_t(split.size()) > max_nodes) break;
    level.clear();
    for (int n : split)
      for (int c : children(n)) level.push_back(c);
  }
  keep_current();
}

void Forest::forget_lazy_nodes() {
  corners_.resize(kept_nodes_), children_.resize(kept_nodes_), root_.resize(kept_nodes_), parent_.resize(kept_nodes_);
  for (auto& c : children_)
    if (c[0] >= kept_nodes_) c = {-1, -1};
  vertices_.resize(kept_vertices_), vertex_root_.resize(kept_vertices_);
  std::erase_if(midpoints_, [&](const auto& e) { return e.second >= kept_vertices_; });
}

std::size_t Forest::memory_bytes() const {
  constexpr std::size_t kPerNode = sizeof(Triangle) + sizeof(std::array<int, 2>) + 2 * sizeof(int);
  constexpr std::size_t kPerVertex = sizeof(Point) + sizeof(int);
  constexpr std::size_t kPerMidpoint = 48;  // unordered_map node + bucket
  return corners_.capacity() * kPerNode + vertices_.capacity() * kPerVertex + midpoints_.size() * kPerMidpoint;
}

void Forest::write(std::ostream& out) const {
  std::vector<std::int32_t> splits;
  for (int n = roots_; n < kept_nodes_; n += 2) splits.push_back(parent_[n]);
  const std::int64_t count = std::int64_t(splits.size());
  out.write(reinterpret_cast<const char*>(&count), sizeof count);
  out.write(reinterpret_cast<const char*>(splits.data()), std::streamsize(splits.size() * sizeof(std::int32_t)));
}

Forest Forest::read(std::istream& in, const Mesh& coarsest) {
  Forest f(coarsest);
  std::int64_t count = 0;
  in.read(reinterpret_cast<char*>(&count), sizeof count);
  if (!in || count < 0 || count > (std::int64_t(1) << 28)) throw std::runtime_error("damaged forest");
  std::vector<std::int32_t> splits(static_cast<std::size_t>(count));
  in.read(reinterpret_cast<char*>(splits.data()), std::streamsize(splits.size() * sizeof(std::int32_t)));
  if (!in) throw std::runtime_error("truncated forest");
  for (std::int32_t n : splits) {
    if (n < 0 || n >= f.node_count() || f.is_split(n)) throw std::runtime_error("damaged forest");
    f.children(n);
  }
  f.keep_current();
  return f;
}

int Forest::add_node(Triangle t, int root, int parent) {
  // Rotate (keeping orientation) so that the longest edge comes first; equal lengths are
  // ordered by the edge's key, identical for both triangles that share the edge.
  int best = 0;
  for (int k = 1; k < 3; ++k) {
    const double lk = length2(vertices_[t[k]], vertices_[t[(k + 1) % 3]]);
    const double lb = length2(vertices_[t[best]], vertices_[t[(best + 1) % 3]]);
    if (lk > lb || (lk == lb && edge_key(t[k], t[(k + 1) % 3]) < edge_key(t[best], t[(best + 1) % 3]))) best = k;
  }
  corners_.push_back({t[best], t[(best + 1) % 3], t[(best + 2) % 3]});
  children_.push_back({-1, -1});
  root_.push_back(root);
  parent_.push_back(parent);
  return int(corners_.size()) - 1;
}

int Forest::midpoint(int a, int b, int root) {
  auto [it, fresh] = midpoints_.emplace(edge_key(a, b), int(vertices_.size()));
  if (fresh) {
    vertices_.push_back({(vertices_[a].x + vertices_[b].x) / 2, (vertices_[a].y + vertices_[b].y) / 2});
    vertex_root_.push_back(root);
  }
  return it->second;
}

double Forest::area(int node) const {
  const Triangle& t = corners_[node];
  return 0.5 * signed_area2(vertices_[t[0]], vertices_[t[1]], vertices_[t[2]]);
}

std::array<int, 2> Forest::children(int node) {
  if (children_[node][0] < 0) {
    const Triangle t = corners_[node];
    const int root = root_[node];
    const int m = midpoint(t[0], t[1], root);
    // (a, m, c) and (m, b, c) keep the orientation of (a, b, c).
    const int first = add_node({t[0], m, t[2]}, root, node);
    const int second = add_node({m, t[1], t[2]}, root, node);
    children_[node] = {first, second};
  }
  return children_[node];
}

}  // namespace zoomwarp::warp
