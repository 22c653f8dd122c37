#include "warp/methods/polyfem/polyfem_system.h"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <stdexcept>

#include "warp/core/parallel_for.h"
#include "warp/methods/polyfem/polyfem_lines.h"
#include "warp/methods/polyfem/serendipity.h"

namespace zoomwarp::warp {

namespace {

// Dunavant's 6-point rule, exact for polynomials of degree 4 on a triangle: barycentric points
// and weights (summing to 1, to be multiplied by the area).
struct Rule {
  std::array<double, 3> l;
  double w;
};
constexpr double kA = 0.445948490915965, kB = 0.091576213509771;
constexpr double kWa = 0.223381589678011, kWb = 0.109951743655322;
constexpr Rule kDunavant4[6] = {{{kA, kA, 1 - 2 * kA}, kWa}, {{kA, 1 - 2 * kA, kA}, kWa}, {{1 - 2 * kA, kA, kA}, kWa},
                                {{kB, kB, 1 - 2 * kB}, kWb}, {{kB, 1 - 2 * kB, kB}, kWb}, {{1 - 2 * kB, kB, kB}, kWb}};

double area(const Point& a, const Point& b, const Point& c) { return std::abs(signed_area2(a, b, c)) / 2; }

// Calls f(point, weight) for every quadrature point of triangle (a, b, c), split in four until
// each piece is at most max_area.
template <class F>
void integrate_triangle(const Point& a, const Point& b, const Point& c, double max_area, F&& f) {
  const double A = area(a, b, c);
  if (A > max_area) {
    const Point ab{(a.x + b.x) / 2, (a.y + b.y) / 2}, bc{(b.x + c.x) / 2, (b.y + c.y) / 2},
        ca{(c.x + a.x) / 2, (c.y + a.y) / 2};
    integrate_triangle(a, ab, ca, max_area, f);
    integrate_triangle(ab, b, bc, max_area, f);
    integrate_triangle(ca, bc, c, max_area, f);
    integrate_triangle(ab, bc, ca, max_area, f);
    return;
  }
  for (const Rule& r : kDunavant4)
    f(Point{r.l[0] * a.x + r.l[1] * b.x + r.l[2] * c.x, r.l[0] * a.y + r.l[1] * b.y + r.l[2] * c.y}, r.w * A);
}

// Calls f(point, weight) for every quadrature point of the element's fan.
template <class F>
void integrate_cell(const PolyfemElement& e, double max_area, F&& f) {
  const std::size_t n = e.polygon.size();
  for (std::size_t i = 0; i < n; ++i) integrate_triangle(e.centroid, e.polygon[i], e.polygon[(i + 1) % n], max_area, f);
}

// K = ∫ s ∇B_k·∇B_l and the loads b_x = ∫ s ∂x B_k, b_y = ∫ s ∂y B_k.
struct Assembled {
  Eigen::SparseMatrix<double> stiffness;
  Eigen::VectorXd load_x, load_y;
};

// One cell's share of K (m × m, row-major over its local nodes) and of the loads (∫ s ∇B_a).
struct CellIntegrals {
  std::vector<double> k;
  std::vector<Point> load;
};

CellIntegrals integrate_cell_stiffness(const PolyfemElement& e, std::size_t m, const ScalarMap& saliency,
                                       const PolyfemOptions& options) {
  const std::vector<Point>& polygon = e.polygon;
  const Point& centroid = e.centroid;
  CellIntegrals out{std::vector<double>(m * m, 0.0), std::vector<Point>(m, Point{0, 0})};
  // The quadrature points with their weights (area × s), and the basis' gradients there (m a
  // point, point after point).
  struct Sample {
    double area_weight, s;
  };
  std::vector<Sample> samples;
  std::vector<Point> gradients;
  std::vector<double> psi;
  std::vector<Point> grad;
  std::vector<Point> quadrature_sum(m, Point{0, 0});
  double cell_area = 0;
  integrate_cell(e, options.max_triangle_area, [&](const Point& p, double w) {
    serendipity_basis(polygon, e.diagonals, p, psi, grad);
    for (std::size_t a = 0; a < m; ++a)
      quadrature_sum[a] = {quadrature_sum[a].x + w * grad[a].x, quadrature_sum[a].y + w * grad[a].y};
    cell_area += w;
    samples.push_back({w, options.saliency_floor + (1 - options.saliency_floor) * saliency.at(p)});
    gradients.insert(gradients.end(), grad.begin(), grad.begin() + std::ptrdiff_t(m));
  });
  // Polynomial consistency (ours, after [Talischi]'s corrected quadrature for polygonal
  // elements): the basis is rational, so quadrature misses ∫ ∇B_a = ∮ B_a·n, which the patch
  // test needs exactly. On the boundary B_a is the 1-D P2 basis of each edge's three nodes
  // (∫ = L/6 at either end, 2L/3 at the midpoint), so ∮ B_a·n is exact; each gradient is
  // shifted by one constant per cell so that the quadrature sum equals it.
  std::vector<Point> boundary_sum(m, Point{0, 0});
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Point a = polygon[i], b = polygon[(i + 1) % n];
    Point normal{b.y - a.y, a.x - b.x};  // |normal| = edge length; pointed away from the centroid
    if (normal.x * ((a.x + b.x) / 2 - centroid.x) + normal.y * ((a.y + b.y) / 2 - centroid.y) < 0)
      normal = {-normal.x, -normal.y};
    const auto add = [&](std::size_t node, double share) {
      boundary_sum[node] = {boundary_sum[node].x + share * normal.x, boundary_sum[node].y + share * normal.y};
    };
    add(i, 1.0 / 6), add((i + 1) % n, 1.0 / 6), add(n + i, 2.0 / 3);
  }
  std::vector<Point> shift(m);
  for (std::size_t a = 0; a < m; ++a)
    shift[a] = {(boundary_sum[a].x - quadrature_sum[a].x) / cell_area, (boundary_sum[a].y - quadrature_sum[a].y) / cell_area};
  for (std::size_t q = 0; q < samples.size(); ++q) {
    const double w = samples[q].area_weight * samples[q].s;
    Point* g = gradients.data() + q * m;
    for (std::size_t a = 0; a < m; ++a) g[a] = {g[a].x + shift[a].x, g[a].y + shift[a].y};
    for (std::size_t a = 0; a < m; ++a) {
      out.load[a] = {out.load[a].x + w * g[a].x, out.load[a].y + w * g[a].y};
      for (std::size_t b = 0; b < m; ++b) out.k[a * m + b] += w * (g[a].x * g[b].x + g[a].y * g[b].y);
    }
  }
  return out;
}

// The cells integrated in parallel, then summed in cell order, so K is the same to the bit on
// any number of threads.
Assembled assemble(const PolygonMesh& mesh, const PolyfemNodes& nodes, const ScalarMap& saliency,
                   const PolyfemOptions& options) {
  const int n_nodes = int(nodes.positions.size());
  std::vector<CellIntegrals> cells(mesh.cells.size());
  parallel_for(int(mesh.cells.size()), [&](int c) {
    cells[c] = integrate_cell_stiffness(PolyfemElement(mesh, c), nodes.cell_nodes[c].size(), saliency, options);
  });
  std::vector<Eigen::Triplet<double>> triplets;
  Assembled out{Eigen::SparseMatrix<double>(n_nodes, n_nodes), Eigen::VectorXd::Zero(n_nodes), Eigen::VectorXd::Zero(n_nodes)};
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) {
    const std::vector<int>& local = nodes.cell_nodes[c];
    const std::size_t m = local.size();
    for (std::size_t a = 0; a < m; ++a) {
      out.load_x[local[a]] += cells[c].load[a].x;
      out.load_y[local[a]] += cells[c].load[a].y;
      for (std::size_t b = 0; b < m; ++b) triplets.emplace_back(local[a], local[b], cells[c].k[a * m + b]);
    }
  }
  out.stiffness.setFromTriplets(triplets.begin(), triplets.end());
  return out;
}

// The Dirichlet problem of one axis: K_ff·c_f = rhs_f − K_fb·c_b, with c fixed where `fixed`
// holds its value (NaN: free). `lu` picks the factorization (the direct solve uses another one).
std::vector<double> solve_axis(const Eigen::SparseMatrix<double>& k, const Eigen::VectorXd& rhs,
                               const std::vector<double>& fixed, bool lu) {
  const int n = int(fixed.size());
  std::vector<int> free_index(n, -1);
  int free = 0;
  for (int i = 0; i < n; ++i)
    if (std::isnan(fixed[i])) free_index[i] = free++;
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::VectorXd b = Eigen::VectorXd::Zero(free);
  for (int i = 0; i < n; ++i)
    if (free_index[i] >= 0) b[free_index[i]] = rhs[i];
  for (int col = 0; col < k.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(k, col); it; ++it) {
      const int r = int(it.row()), c = int(it.col());
      if (free_index[r] < 0) continue;
      if (free_index[c] >= 0) triplets.emplace_back(free_index[r], free_index[c], it.value());
      else b[free_index[r]] -= it.value() * fixed[c];
    }
  std::vector<double> out(fixed);
  if (free > 0) {
    Eigen::SparseMatrix<double> kff(free, free);
    kff.setFromTriplets(triplets.begin(), triplets.end());
    Eigen::VectorXd x;
    if (lu) {
      const Eigen::SparseLU<Eigen::SparseMatrix<double>> solver(kff);
      if (solver.info() != Eigen::Success) throw std::runtime_error("polyfem: the system could not be factored");
      x = solver.solve(b);
    } else {
      const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(kff);
      if (solver.info() != Eigen::Success) throw std::runtime_error("polyfem: the system could not be factored");
      x = solver.solve(b);
    }
    for (int i = 0; i < n; ++i)
      if (free_index[i] >= 0) out[i] = x[free_index[i]];
  }
  return out;
}

// Boundary values of one axis [eq. 12]: on the low border `low`, on the high one `high`, NaN
// (free) elsewhere.
std::vector<double> boundary(const PolyfemNodes& nodes, bool x_axis, double extent, double low, double high) {
  std::vector<double> fixed(nodes.positions.size(), std::nan(""));
  for (std::size_t i = 0; i < fixed.size(); ++i) {
    const double c = x_axis ? nodes.positions[i].x : nodes.positions[i].y;
    if (c == 0) fixed[i] = low;
    else if (c == extent) fixed[i] = high;
  }
  return fixed;
}

// K + L (L's upper triangle mirrored); K itself when L is empty.
Eigen::SparseMatrix<double> plus(const Eigen::SparseMatrix<double>& k, const SymmetricMatrix& l) {
  if (l.value.empty()) return k;
  std::vector<Eigen::Triplet<double>> triplets;
  for (std::size_t e = 0; e < l.value.size(); ++e) {
    triplets.emplace_back(l.row[e], l.col[e], l.value[e]);
    if (l.row[e] != l.col[e]) triplets.emplace_back(l.col[e], l.row[e], l.value[e]);
  }
  Eigen::SparseMatrix<double> m(k.rows(), k.cols());
  m.setFromTriplets(triplets.begin(), triplets.end());
  return k + m;
}

void check_mesh(const PolygonMesh& mesh) {
  if (!(mesh.width > 0 && mesh.height > 0) || mesh.cells.empty()) throw std::invalid_argument("polyfem: an empty mesh");
  for (const auto& cell : mesh.cells) {
    if (cell.size() < 3) throw std::invalid_argument("polyfem: a cell with fewer than 3 vertices");
    for (int v : cell)
      if (v < 0 || std::size_t(v) >= mesh.vertices.size()) throw std::invalid_argument("polyfem: a vertex out of range");
  }
}

}  // namespace

PolyfemElement::PolyfemElement(const PolygonMesh& mesh, int cell) {
  for (int v : mesh.cells.at(cell)) polygon.push_back(mesh.vertices[v]);
  diagonals = serendipity_coefficients(polygon);
  for (const Point& p : polygon) centroid = {centroid.x + p.x / polygon.size(), centroid.y + p.y / polygon.size()};
}

double ScalarMap::at(const Point& p) const {
  if (values.empty() || map_w <= 0 || map_h <= 0) return 0;
  const double fx = std::clamp(p.x / width * map_w - 0.5, 0.0, double(map_w - 1));
  const double fy = std::clamp(p.y / height * map_h - 0.5, 0.0, double(map_h - 1));
  const int x0 = std::min(int(fx), map_w - 1), y0 = std::min(int(fy), map_h - 1);
  const int x1 = std::min(x0 + 1, map_w - 1), y1 = std::min(y0 + 1, map_h - 1);
  const double u = fx - x0, v = fy - y0;
  const auto val = [&](int x, int y) { return double(values[std::size_t(y) * map_w + x]); };
  return (1 - u) * (1 - v) * val(x0, y0) + u * (1 - v) * val(x1, y0) + (1 - u) * v * val(x0, y1) + u * v * val(x1, y1);
}

PolyfemNodes polyfem_nodes(const PolygonMesh& mesh) {
  check_mesh(mesh);
  PolyfemNodes nodes;
  nodes.positions = mesh.vertices;
  nodes.vertex_count = int(mesh.vertices.size());
  std::map<std::pair<int, int>, int> edge_node;
  for (const auto& cell : mesh.cells) {
    std::vector<int> local(cell.begin(), cell.end());
    for (std::size_t i = 0; i < cell.size(); ++i) {
      const int a = cell[i], b = cell[(i + 1) % cell.size()];
      const auto key = std::minmax(a, b);
      auto it = edge_node.find(key);
      if (it == edge_node.end()) {
        it = edge_node.emplace(key, int(nodes.positions.size())).first;
        const Point &pa = mesh.vertices[a], &pb = mesh.vertices[b];
        // A border edge's midpoint lies exactly on the border, as its ends do.
        Point mid{(pa.x + pb.x) / 2, (pa.y + pb.y) / 2};
        if (pa.x == pb.x) mid.x = pa.x;
        if (pa.y == pb.y) mid.y = pa.y;
        nodes.positions.push_back(mid);
      }
      local.push_back(it->second);
    }
    nodes.cell_nodes.push_back(std::move(local));
  }
  return nodes;
}

PolyfemSolution solve_polyfem(const PolygonMesh& mesh, const ScalarMap& saliency, const PolyfemOptions& options,
                              const std::vector<Segment>& lines) {
  PolyfemSolution s;
  s.nodes = polyfem_nodes(mesh);
  const Assembled k = assemble(mesh, s.nodes, saliency, options);
  PolyfemLineTerm l = polyfem_line_term(mesh, s.nodes, lines, options);
  const Eigen::VectorXd none = Eigen::VectorXd::Zero(Eigen::Index(s.nodes.positions.size()));
  s.g_x = solve_axis(plus(k.stiffness, l.x), none, boundary(s.nodes, true, mesh.width, 0, 1), false);
  s.g_y = solve_axis(plus(k.stiffness, l.y), none, boundary(s.nodes, false, mesh.height, 0, 1), false);
  s.line_x = std::move(l.x), s.line_y = std::move(l.y);
  s.stiffness.size = int(k.stiffness.rows());
  for (int col = 0; col < k.stiffness.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(k.stiffness, col); it; ++it)
      if (it.row() <= it.col()) {
        s.stiffness.row.push_back(int(it.row()));
        s.stiffness.col.push_back(int(it.col()));
        s.stiffness.value.push_back(it.value());
      }
  return s;
}

AspectRange polyfem_fold_free_range(const PolygonMesh& mesh, const PolyfemSolution& solution,
                                    const PolyfemOptions& options) {
  check_mesh(mesh);
  const double W = mesh.width, H = mesh.height;
  // Narrows (u_low, u_high) to the roots of 1 + B·u + C·u² nearest 0.
  const auto bound = [](double B, double C, double& u_low, double& u_high) {
    if (C == 0) {
      if (B > 0) u_low = std::max(u_low, -1 / B);
      if (B < 0) u_high = std::min(u_high, -1 / B);
      return;
    }
    const double disc = B * B - 4 * C;
    if (disc < 0) return;  // no real root: positive for every u
    // Roots by the stable form; their product is 1/C.
    const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
    for (const double root : {q / C, q != 0 ? 1 / q : std::nan("")}) {
      if (root > 0) u_high = std::min(u_high, root);
      if (root < 0) u_low = std::max(u_low, root);
    }
  };
  // Per cell (the cells in parallel), then the narrowest of all: min and max, in any order.
  std::vector<std::pair<double, double>> cell_range(mesh.cells.size());
  parallel_for(int(mesh.cells.size()), [&](int c) {
    const PolyfemElement e(mesh, c);
    const std::vector<int>& local = solution.nodes.cell_nodes[c];
    double u_low = -1, u_high = AspectRange::kUnboundedAspect - 1;
    std::vector<double> psi;
    std::vector<Point> grad;
    integrate_cell(e, options.max_triangle_area, [&](const Point& p, double) {
      serendipity_basis(e.polygon, e.diagonals, p, psi, grad);
      Point gx{0, 0}, gy{0, 0};  // ∇G_x, ∇G_y
      for (std::size_t a = 0; a < local.size(); ++a) {
        gx = {gx.x + solution.g_x[local[a]] * grad[a].x, gx.y + solution.g_x[local[a]] * grad[a].y};
        gy = {gy.x + solution.g_y[local[a]] * grad[a].x, gy.y + solution.g_y[local[a]] * grad[a].y};
      }
      bound(1 + W * gx.x - H * gy.y, W * gx.x * (1 - H * gy.y) + W * H * gx.y * gy.x, u_low, u_high);
    });
    cell_range[c] = {u_low, u_high};
  });
  double u_low = -1, u_high = AspectRange::kUnboundedAspect - 1;
  for (const auto& [low, high] : cell_range) u_low = std::max(u_low, low), u_high = std::min(u_high, high);
  return {1 + u_low, 1 + u_high};
}

std::vector<Point> polyfem_g_field(const PolyfemSolution& s) {
  std::vector<Point> g(s.g_x.size());
  for (std::size_t k = 0; k < g.size(); ++k) g[k] = {s.g_x[k], s.g_y[k]};
  return g;
}

std::vector<Point> polyfem_positions(const PolyfemSolution& s, double width, double height, double target_w,
                                     double target_h) {
  const double dw = target_w - width, dh = target_h - height;
  std::vector<Point> out(s.nodes.positions.size());
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = {s.nodes.positions[i].x + dw * s.g_x[i], s.nodes.positions[i].y + dh * s.g_y[i]};
  return out;
}

std::vector<Point> solve_polyfem_direct(const PolygonMesh& mesh, const ScalarMap& saliency, double target_w,
                                        double target_h, const PolyfemOptions& options,
                                        const std::vector<Segment>& lines) {
  const PolyfemNodes nodes = polyfem_nodes(mesh);
  const Assembled k = assemble(mesh, nodes, saliency, options);
  const PolyfemLineTerm l = polyfem_line_term(mesh, nodes, lines, options);
  // ∂E/∂c = 2((K + L_a)·c − b): the loads carry the identity's pull e_a; E_L has none.
  const std::vector<double> x =
      solve_axis(plus(k.stiffness, l.x), k.load_x, boundary(nodes, true, mesh.width, 0, target_w), true);
  const std::vector<double> y =
      solve_axis(plus(k.stiffness, l.y), k.load_y, boundary(nodes, false, mesh.height, 0, target_h), true);
  std::vector<Point> out(x.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {x[i], y[i]};
  return out;
}

}  // namespace zoomwarp::warp
