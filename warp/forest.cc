#include "warp/forest.h"

#include <cmath>

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
