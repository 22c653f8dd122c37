#include "warp/methods/patch/patch_energy.h"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

namespace zoomwarp::warp {

namespace {

// One linear residual r = Σ c_k·u_k + per_w·W' + per_h·H' over the grid's coordinates
// u (x of vertex v at 2v, y at 2v + 1), minimised as weight·r².
struct Residual {
  std::vector<std::pair<int, double>> terms;
  double per_w = 0, per_h = 0;
  double weight = 1;
};

int x_of(int v) { return 2 * v; }
int y_of(int v) { return 2 * v + 1; }

// Point p written affinely in the triangle holding it, as patch_mesh splits each quad (along
// its (top-left, bottom-right) diagonal) and the client draws it: the three corners and their
// weights. A point on an edge gets the same weights from either side.
std::array<std::pair<int, double>, 3> affine(const PatchGrid& g, const Point& p) {
  const double fx = std::clamp(p.x / g.width * g.nx, 0.0, double(g.nx)), fy = std::clamp(p.y / g.height * g.ny, 0.0, double(g.ny));
  const int i = std::min(g.nx - 1, int(fx)), j = std::min(g.ny - 1, int(fy));
  const double u = fx - i, v = fy - j;
  if (u >= v) return {{{g.vertex(i, j), 1 - u}, {g.vertex(i + 1, j), u - v}, {g.vertex(i + 1, j + 1), v}}};
  return {{{g.vertex(i, j), 1 - v}, {g.vertex(i + 1, j + 1), u}, {g.vertex(i, j + 1), v - u}}};
}

// The fractions t ∈ (0, 1) at which segment l crosses an edge of the triangulation — in grid
// units (fx, fy) = (x·nx/W, y·ny/H) the vertical sides are fx ∈ ℤ, the horizontal ones fy ∈ ℤ
// and the diagonals fx − fy ∈ ℤ — ascending. Between two of them the warp is affine, so the
// warped line is the polyline through the warped crossings.
std::vector<double> crossings(const PatchGrid& g, const Segment& l) {
  const double ax = l.a.x / g.width * g.nx, ay = l.a.y / g.height * g.ny;
  const double bx = l.b.x / g.width * g.nx, by = l.b.y / g.height * g.ny;
  std::vector<double> t;
  for (const auto& [f0, f1] : {std::pair{ax, bx}, std::pair{ay, by}, std::pair{ax - ay, bx - by}}) {
    if (f0 == f1) continue;
    for (double k = std::floor(std::min(f0, f1)) + 1; k < std::max(f0, f1); ++k) t.push_back((k - f0) / (f1 - f0));
  }
  std::sort(t.begin(), t.end());
  return t;
}

// The quad's four edges, each from its top/left end: top, bottom, left, right.
std::array<std::pair<int, int>, 4> quad_edges(const PatchGrid& g, int i, int j) {
  return {{{g.vertex(i, j), g.vertex(i + 1, j)},
           {g.vertex(i, j + 1), g.vertex(i + 1, j + 1)},
           {g.vertex(i, j), g.vertex(i, j + 1)},
           {g.vertex(i + 1, j), g.vertex(i + 1, j + 1)}}};
}

Point source(const PatchGrid& g, int v) { return g.position(v % (g.nx + 1), v / (g.nx + 1)); }

std::vector<Residual> residuals(const PatchGrid& g, const std::vector<Segment>& lines, const PatchEnergyOptions& o) {
  std::vector<Residual> out;
  // E(i): the edges of patch i's quads, each once per patch.
  std::vector<std::set<std::pair<int, int>>> edges(g.significance.size());
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i)
      for (const auto& e : quad_edges(g, i, j)) edges[g.quad_patch[j * g.nx + i]].insert(e);
  for (std::size_t p = 0; p < edges.size(); ++p) {
    if (edges[p].empty()) continue;  // a patch owning no quad gets no energy [METHODS §2]
    const double s_i = g.significance[p];
    // The representative edge C_i: midpoint nearest the centroid of the patch's quads' vertices.
    Point centroid{0, 0};
    for (const auto& [a, b] : edges[p]) {
      const Point pa = source(g, a), pb = source(g, b);
      centroid = {centroid.x + (pa.x + pb.x) / 2, centroid.y + (pa.y + pb.y) / 2};
    }
    centroid = {centroid.x / edges[p].size(), centroid.y / edges[p].size()};
    std::pair<int, int> rep = *edges[p].begin();
    double best = 1e300;
    for (const auto& [a, b] : edges[p]) {
      const Point pa = source(g, a), pb = source(g, b);
      const double d = std::hypot((pa.x + pb.x) / 2 - centroid.x, (pa.y + pb.y) / 2 - centroid.y);
      if (d < best) best = d, rep = {a, b};
    }
    const Point c0 = source(g, rep.first), c1 = source(g, rep.second);
    const double cx = c1.x - c0.x, cy = c1.y - c0.y, c2 = cx * cx + cy * cy;
    for (const auto& [a, b] : edges[p]) {
      const Point pa = source(g, a), pb = source(g, b);
      const double ex = pb.x - pa.x, ey = pb.y - pa.y;
      // D_ST [eqs 1–2]: e'_j − T_ij·C'_i, T = [[s, r], [−r, s]].
      const double w_st = o.similarity_weight * o.alpha * s_i;
      if (w_st > 0 && std::make_pair(a, b) != rep) {
        const double s = (cx * ex + cy * ey) / c2, r = (cy * ex - cx * ey) / c2;
        const int c0v = rep.first, c1v = rep.second;
        out.push_back({{{x_of(b), 1}, {x_of(a), -1}, {x_of(c1v), -s}, {x_of(c0v), s}, {y_of(c1v), -r}, {y_of(c0v), r}}, 0, 0, w_st});
        out.push_back({{{y_of(b), 1}, {y_of(a), -1}, {x_of(c1v), r}, {x_of(c0v), -r}, {y_of(c1v), -s}, {y_of(c0v), s}}, 0, 0, w_st});
      }
      // D_LT [eq. 3 corrected]: e'_j − L·e_j.
      const double w_lt = (1 - o.alpha) * (1 - s_i);
      if (w_lt > 0) {
        out.push_back({{{x_of(b), 1}, {x_of(a), -1}}, -ex / g.width, 0, w_lt});
        out.push_back({{{y_of(b), 1}, {y_of(a), -1}}, 0, -ey / g.height, w_lt});
      }
    }
  }
  // D_OR [eq. 5]: horizontal edges keep their y, vertical ones their x.
  if (o.orientation_weight > 0)
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) {
        const int a = g.vertex(i, j), b = g.vertex(i + 1, j), d = g.vertex(i, j + 1), c = g.vertex(i + 1, j + 1);
        out.push_back({{{y_of(a), 1}, {y_of(b), -1}}, 0, 0, o.orientation_weight});
        out.push_back({{{y_of(d), 1}, {y_of(c), -1}}, 0, 0, o.orientation_weight});
        out.push_back({{{x_of(a), 1}, {x_of(d), -1}}, 0, 0, o.orientation_weight});
        out.push_back({{{x_of(b), 1}, {x_of(c), -1}}, 0, 0, o.orientation_weight});
      }
  // Lines (ours): every crossing with a triangle edge stays at its fraction between the warped ends.
  for (const Segment& l : lines) {
    if (o.line_weight <= 0) continue;
    const auto qa = affine(g, l.a), qb = affine(g, l.b);
    for (double t : crossings(g, l)) {
      const auto qk = affine(g, {l.a.x + t * (l.b.x - l.a.x), l.a.y + t * (l.b.y - l.a.y)});
      for (auto coord : {x_of, y_of}) {
        Residual r;
        r.weight = o.line_weight;
        for (const auto& [v, w] : qk) r.terms.emplace_back(coord(v), w);
        for (const auto& [v, w] : qa) r.terms.emplace_back(coord(v), -(1 - t) * w);
        for (const auto& [v, w] : qb) r.terms.emplace_back(coord(v), -t * w);
        out.push_back(std::move(r));
      }
    }
  }
  // ε·|V' − V'_stretch|².
  for (int v = 0; v < (g.nx + 1) * (g.ny + 1); ++v) {
    const Point p = source(g, v);
    out.push_back({{{x_of(v), 1}}, -p.x / g.width, 0, o.regularisation});
    out.push_back({{{y_of(v), 1}}, 0, -p.y / g.height, o.regularisation});
  }
  return out;
}

// Which grid coordinates are unknowns: per coordinate its free index, or −1 and its value per
// unit W' and per unit H' — the hard boundary: x' = 0 / W' on the left / right column, y' = 0 /
// H' on the top / bottom row.
struct Unknowns {
  std::vector<int> free;
  std::vector<double> fixed_w, fixed_h;
  int count = 0;
};
Unknowns unknowns_of(const PatchGrid& g) {
  const int n = 2 * (g.nx + 1) * (g.ny + 1);
  Unknowns u{std::vector<int>(n, -1), std::vector<double>(n, 0), std::vector<double>(n, 0), 0};
  for (int j = 0; j <= g.ny; ++j)
    for (int i = 0; i <= g.nx; ++i) {
      const int v = g.vertex(i, j);
      if (i == g.nx) u.fixed_w[x_of(v)] = 1;
      if (j == g.ny) u.fixed_h[y_of(v)] = 1;
      if (i != 0 && i != g.nx) u.free[x_of(v)] = u.count++;
      if (j != 0 && j != g.ny) u.free[y_of(v)] = u.count++;
    }
  return u;
}

// The normal equations Σ weight·c·cᵀ over the free coordinates, and their right-hand sides for
// targets (1, 0) and (0, 1).
struct NormalEquations {
  Eigen::SparseMatrix<double> matrix;
  Eigen::VectorXd per_w, per_h;
};
NormalEquations normal_equations(const Unknowns& u, const std::vector<Residual>& rs) {
  std::vector<Eigen::Triplet<double>> triplets;
  NormalEquations e{Eigen::SparseMatrix<double>(u.count, u.count), Eigen::VectorXd::Zero(u.count),
                    Eigen::VectorXd::Zero(u.count)};
  for (const Residual& r : rs) {
    double cw = r.per_w, ch = r.per_h;
    for (const auto& [k, c] : r.terms)
      if (u.free[k] < 0) cw += c * u.fixed_w[k], ch += c * u.fixed_h[k];
    for (const auto& [k, c] : r.terms) {
      if (u.free[k] < 0) continue;
      e.per_w[u.free[k]] -= r.weight * c * cw;
      e.per_h[u.free[k]] -= r.weight * c * ch;
      for (const auto& [k2, c2] : r.terms)
        if (u.free[k2] >= 0) triplets.emplace_back(u.free[k], u.free[k2], r.weight * c * c2);
    }
  }
  e.matrix.setFromTriplets(triplets.begin(), triplets.end());
  return e;
}

// Every coordinate's value from the free ones' solution `x` and the target.
std::vector<Point> positions_of(const Unknowns& u, const Eigen::VectorXd& x, double tw, double th) {
  std::vector<Point> out(u.free.size() / 2);
  for (std::size_t k = 0; k < u.free.size(); ++k) {
    const double value = u.free[k] >= 0 ? x[u.free[k]] : tw * u.fixed_w[k] + th * u.fixed_h[k];
    (k % 2 == 0 ? out[k / 2].x : out[k / 2].y) = value;
  }
  return out;
}

void check_grid(const PatchGrid& g) {
  if (!(g.width > 0 && g.height > 0 && g.nx >= 1 && g.ny >= 1) || g.quad_patch.size() != std::size_t(g.nx) * g.ny)
    throw std::invalid_argument("patch energy: a grid of at least one quad is needed");
  for (int p : g.quad_patch)
    if (p < 0 || std::size_t(p) >= g.significance.size()) throw std::invalid_argument("patch energy: quad patch out of range");
}

}  // namespace

PatchGrid make_patch_grid(const Patches& patches, const SignificanceMap& saliency, double analysis_scale,
                          const PatchEnergyOptions& options) {
  if (patches.count == 0 || patches.width < 1 || patches.height < 1)
    throw std::invalid_argument("patch grid: no patches");
  PatchGrid g;
  g.width = patches.width;
  g.height = patches.height;
  g.nx = std::max(1, int(std::lround(g.width / options.quad_size)));
  g.ny = std::max(1, int(std::lround(g.height / options.quad_size)));
  // s_i: the mean saliency over the patch's pixels, over the largest patch mean (ours: [Lin13]
  // only says s_i ∈ [0, 1]).
  std::vector<double> sum(patches.count, 0);
  const double k = saliency.values.empty() ? 0 : saliency.scale / analysis_scale;  // map px per analysis px
  std::vector<std::map<int, int>> votes(std::size_t(g.nx) * g.ny);
  for (int y = 0; y < patches.height; ++y)
    for (int x = 0; x < patches.width; ++x) {
      const int label = patches.label[std::size_t(y) * patches.width + x];
      if (k > 0) {
        const int mx = std::clamp(int((x + 0.5) * k), 0, saliency.width - 1);
        const int my = std::clamp(int((y + 0.5) * k), 0, saliency.height - 1);
        sum[label] += saliency.at(mx, my);
      }
      const int qi = std::min(g.nx - 1, int((x + 0.5) * g.nx / g.width));
      const int qj = std::min(g.ny - 1, int((y + 0.5) * g.ny / g.height));
      ++votes[std::size_t(qj) * g.nx + qi][label];
    }
  // A quad belongs to the patch covering most of its pixels (ties: the lower label).
  g.quad_patch.resize(votes.size());
  for (std::size_t q = 0; q < votes.size(); ++q) {
    int best = 0, count = -1;
    for (const auto& [label, n] : votes[q])
      if (n > count) best = label, count = n;
    g.quad_patch[q] = best;
  }
  // Normalised by the largest mean among patches that own a quad (ours): a few-pixel patch on a
  // saliency peak, owning no quad and so no energy, would otherwise set the scale for all.
  g.significance.resize(patches.count);
  for (int p = 0; p < patches.count; ++p) g.significance[p] = sum[p] / patches.size[p];
  double top = 0;
  for (int p : g.quad_patch) top = std::max(top, g.significance[p]);
  for (double& s : g.significance) s = top > 0 ? std::min(1.0, s / top) : 0;
  return g;
}

PatchBasis solve_patch_basis(const PatchGrid& grid, const std::vector<Segment>& lines, const PatchEnergyOptions& options) {
  check_grid(grid);
  const Unknowns u = unknowns_of(grid);
  const NormalEquations e = normal_equations(u, residuals(grid, lines, options));
  Eigen::VectorXd xw = Eigen::VectorXd::Zero(u.count), xh = Eigen::VectorXd::Zero(u.count);
  if (u.count > 0) {
    const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(e.matrix);
    if (solver.info() != Eigen::Success) throw std::runtime_error("patch energy: the system could not be factored");
    xw = solver.solve(e.per_w);
    xh = solver.solve(e.per_h);
  }
  return {positions_of(u, xw, 1, 0), positions_of(u, xh, 0, 1)};
}

std::vector<Point> solve_patch_direct(const PatchGrid& grid, const std::vector<Segment>& lines, double target_w,
                                      double target_h, const PatchEnergyOptions& options) {
  check_grid(grid);
  // The same normal equations with this one target's right-hand side, solved by another
  // factorization (LU): what the basis must reproduce.
  const Unknowns u = unknowns_of(grid);
  const NormalEquations e = normal_equations(u, residuals(grid, lines, options));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(u.count);
  if (u.count > 0) {
    const Eigen::SparseLU<Eigen::SparseMatrix<double>> solver(e.matrix);
    if (solver.info() != Eigen::Success) throw std::runtime_error("patch energy: the system could not be factored");
    x = solver.solve(target_w * e.per_w + target_h * e.per_h);
  }
  return positions_of(u, x, target_w, target_h);
}

}  // namespace zoomwarp::warp
