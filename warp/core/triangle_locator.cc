#include "warp/core/triangle_locator.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace zoomwarp::warp {

namespace {

// Triangles are listed in the cells their bounding box meets once widened by this × the mesh's
// extent E. A point outside a triangle's widened box by δ has a barycentric coordinate below
// −δ / (2 × the triangle's width) ≤ −kMargin / 2, while a computed coordinate errs by about
// 1e-16 × E / the triangle's height: so, but for slivers of aspect ~10⁶, a triangle missing
// from p's cell computes a coordinate below −kMargin / 2 for p — never ≥ 0, and never within
// kNearlyInside of 0.
constexpr double kMargin = 1e-9, kNearlyInside = -kMargin / 4;

// A triangle's bounding box, widened by `margin` on every side.
struct Box {
  double x0, y0, x1, y1;
};

Box widened_box(const Mesh& mesh, const Triangle& t, double margin) {
  const Point &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
  return {std::min({a.x, b.x, c.x}) - margin, std::min({a.y, b.y, c.y}) - margin, std::max({a.x, b.x, c.x}) + margin,
          std::max({a.y, b.y, c.y}) + margin};
}

}  // namespace

TriangleLocator::TriangleLocator(const Mesh& mesh) : mesh_(mesh) {
  if (mesh.triangles.empty()) return;
  double x0 = mesh.vertices[mesh.triangles[0][0]].x, x1 = x0, y0 = mesh.vertices[mesh.triangles[0][0]].y, y1 = y0;
  for (const Triangle& t : mesh.triangles)
    for (int v : t) {
      x0 = std::min(x0, mesh.vertices[v].x), x1 = std::max(x1, mesh.vertices[v].x);
      y0 = std::min(y0, mesh.vertices[v].y), y1 = std::max(y1, mesh.vertices[v].y);
    }
  const double margin = kMargin * std::max({x1 - x0, y1 - y0, 1.0});
  x0_ = x0 - margin, y0_ = y0 - margin;
  const double w = x1 - x0 + 2 * margin, h = y1 - y0 + 2 * margin;
  // About kPerCell triangles a cell: a triangle's box then meets few cells (building is most of
  // the cost: a geomorph locates a few hundred points in meshes of a few thousand triangles).
  constexpr double kPerCell = 4;
  const double cells = std::max(1.0, double(mesh.triangles.size()) / kPerCell);
  nx_ = std::clamp(int(std::ceil(std::sqrt(cells * w / h))), 1, 4096);
  ny_ = std::clamp(int(std::ceil(cells / nx_)), 1, 4096);
  cell_w_ = w / nx_, cell_h_ = h / ny_;
  per_cell_w_ = nx_ / w, per_cell_h_ = ny_ / h;

  // Two passes (count, then fill) over each triangle's cells, filled in mesh order.
  struct CellRange {
    int x0, y0, x1, y1;
  };
  std::vector<CellRange> ranges(mesh.triangles.size());
  start_.assign(std::size_t(nx_) * ny_ + 1, 0);
  for (std::size_t f = 0; f < ranges.size(); ++f) {
    const Box b = widened_box(mesh, mesh.triangles[f], margin);
    CellRange& r = ranges[f];
    r = {cell_x(b.x0), cell_y(b.y0), cell_x(b.x1), cell_y(b.y1)};
    for (int cy = r.y0; cy <= r.y1; ++cy)
      for (int cx = r.x0; cx <= r.x1; ++cx) ++start_[std::size_t(cy) * nx_ + cx + 1];
  }
  for (std::size_t c = 0; c + 1 < start_.size(); ++c) start_[c + 1] += start_[c];
  triangles_.resize(std::size_t(start_.back()));
  std::vector<int> next(start_.begin(), start_.end() - 1);
  for (int f = 0; f < int(ranges.size()); ++f)
    for (int cy = ranges[f].y0; cy <= ranges[f].y1; ++cy)
      for (int cx = ranges[f].x0; cx <= ranges[f].x1; ++cx) triangles_[std::size_t(next[std::size_t(cy) * nx_ + cx]++)] = f;
}

int TriangleLocator::cell_x(double x) const { return std::clamp(int(std::floor((x - x0_) * per_cell_w_)), 0, nx_ - 1); }
int TriangleLocator::cell_y(double y) const { return std::clamp(int(std::floor((y - y0_) * per_cell_h_)), 0, ny_ - 1); }

// As locate_in, over p's cell: the first triangle whose smallest coordinate is ≥ 0 is the first
// of all (every such triangle is listed there, in mesh order). When none is — p on an edge or a
// corner, where rounding can make every coordinate of its triangles a hair negative — the
// cell's best is the best of all if it is within kNearlyInside of 0, and its first triangle
// attaining it the first of all. Otherwise (p off the mesh) all triangles are scanned.
MeshPoint TriangleLocator::find(const Point& p) const {
  const bool in_grid = p.x >= x0_ && p.y >= y0_ && p.x <= x0_ + nx_ * cell_w_ && p.y <= y0_ + ny_ * cell_h_;
  if (nx_ > 0 && in_grid) {
    const std::size_t cell = std::size_t(cell_y(p.y)) * nx_ + cell_x(p.x);
    double best = -std::numeric_limits<double>::infinity();
    MeshPoint out;
    for (int k = start_[cell]; k < start_[cell + 1]; ++k) {
      const Triangle& t = mesh_.triangles[triangles_[k]];
      const auto l = barycentric(p, mesh_.vertices[t[0]], mesh_.vertices[t[1]], mesh_.vertices[t[2]]);
      const double inside = std::min({l[0], l[1], l[2]});
      if (inside > best) {
        best = inside, out = {triangles_[k], l};
        if (inside >= 0) return out;
      }
    }
    if (best > kNearlyInside) return out;
  }
  return locate_in(mesh_, p);
}

}  // namespace zoomwarp::warp
