#include "warp/methods/polyfem/polyfem_lines.h"

#include <Eigen/Sparse>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "warp/methods/polyfem/polyfem_export.h"

namespace zoomwarp::warp {

namespace {

// The cell holding p: the one p lies deepest inside (on a shared edge or vertex any of them, the
// basis being continuous there; a point a rounding outside the rectangle, the nearest).
int cell_of(const PolygonMesh& mesh, const std::vector<std::array<double, 4>>& boxes, const Point& p) {
  int best = -1;
  double best_depth = -1e300;
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) {
    const auto& [x0, y0, x1, y1] = boxes[c];
    if (best_depth >= 0 && (p.x < x0 || p.x > x1 || p.y < y0 || p.y > y1)) continue;
    const std::vector<int>& ids = mesh.cells[c];
    double depth = 1e300;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const Point &a = mesh.vertices[ids[i]], &b = mesh.vertices[ids[(i + 1) % ids.size()]];
      depth = std::min(depth, signed_area2(a, b, p) / std::hypot(b.x - a.x, b.y - a.y));
    }
    if (depth > best_depth) best_depth = depth, best = int(c);
  }
  return best;
}

// Upper triangle of a symmetric Eigen matrix as plain data.
SymmetricMatrix upper(const Eigen::SparseMatrix<double>& m) {
  SymmetricMatrix out;
  out.size = int(m.rows());
  for (int col = 0; col < m.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(m, col); it; ++it)
      if (it.row() <= it.col()) out.row.push_back(int(it.row())), out.col.push_back(int(it.col())), out.value.push_back(it.value());
  return out;
}

}  // namespace

PolyfemLineTerm polyfem_line_term(const PolygonMesh& mesh, const PolyfemNodes& nodes, const std::vector<Segment>& lines,
                                  const PolyfemOptions& options) {
  std::vector<std::array<double, 4>> boxes;
  for (const auto& cell : mesh.cells) {
    std::array<double, 4> b{1e300, 1e300, -1e300, -1e300};
    for (int v : cell) {
      const Point& p = mesh.vertices[v];
      b = {std::min(b[0], p.x), std::min(b[1], p.y), std::max(b[2], p.x), std::max(b[3], p.y)};
    }
    boxes.push_back(b);
  }
  const int n_nodes = int(nodes.positions.size());
  std::vector<Eigen::Triplet<double>> tx, ty;
  std::vector<int> node;
  std::vector<double> weight;
  for (const Segment& line : lines) {
    const double length = std::hypot(line.b.x - line.a.x, line.b.y - line.a.y);
    if (!(length >= 1)) continue;
    const double dx = (line.b.x - line.a.x) / length, dy = (line.b.y - line.a.y) / length;
    const int n = std::max(2, int(std::ceil(length / options.line_spacing)));
    const double scale = options.line_weight * double(n) * n * n / 64;
    // Each sample's node weights.
    std::vector<std::map<int, double>> samples(n + 1);
    for (int k = 0; k <= n; ++k) {
      const double t = double(k) / n;
      const Point p{line.a.x + (line.b.x - line.a.x) * t, line.a.y + (line.b.y - line.a.y) * t};
      node.clear(), weight.clear();
      polyfem_point_weights(mesh, nodes, cell_of(mesh, boxes, p), p, node, weight);
      for (std::size_t j = 0; j < node.size(); ++j) samples[k][node[j]] += weight[j];
    }
    for (int k = 1; k < n; ++k) {
      std::map<int, double> row = samples[k - 1];
      for (const auto& [i, w] : samples[k]) row[i] -= 2 * w;
      for (const auto& [i, w] : samples[k + 1]) row[i] += w;
      for (const auto& [i, wi] : row)
        for (const auto& [j, wj] : row) {
          tx.emplace_back(i, j, scale * dy * dy * wi * wj);
          ty.emplace_back(i, j, scale * dx * dx * wi * wj);
        }
    }
  }
  PolyfemLineTerm out;
  if (tx.empty()) return out;
  Eigen::SparseMatrix<double> lx(n_nodes, n_nodes), ly(n_nodes, n_nodes);
  lx.setFromTriplets(tx.begin(), tx.end());
  ly.setFromTriplets(ty.begin(), ty.end());
  return {upper(lx), upper(ly)};
}

}  // namespace zoomwarp::warp
