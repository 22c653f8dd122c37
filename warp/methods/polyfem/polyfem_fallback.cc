#include "warp/methods/polyfem/polyfem_fallback.h"

#include <cmath>
#include <stdexcept>

#include "warp/methods/polyfem/lbfgs_rollback.h"

namespace zoomwarp::warp {

namespace {

// Where each node's x and y live in the variable vector (−1: fixed on the border).
struct Unknowns {
  std::vector<int> x, y;
  int count = 0;
};

Unknowns unknowns_of(const PolygonMesh& mesh, const PolyfemNodes& nodes) {
  Unknowns u;
  for (const Point& p : nodes.positions) u.x.push_back(p.x == 0 || p.x == mesh.width ? -1 : u.count++);
  for (const Point& p : nodes.positions) u.y.push_back(p.y == 0 || p.y == mesh.height ? -1 : u.count++);
  return u;
}

}  // namespace

bool polyfem_cell_folds(const CellSampling& sampling, const std::vector<Point>& displacement) {
  static thread_local std::vector<Point> q;
  q.clear();
  displace_cell_samples(sampling, displacement, q);
  for (const Triangle& t : sampling.triangles)
    if (signed_area2(q[t[0]], q[t[1]], q[t[2]]) <= 0) return true;
  return false;
}

PolyfemFallback polyfem_fallback(const PolygonMesh& mesh, const PolyfemSolution& solution,
                                 const std::vector<CellSampling>& check, double delta_w, double delta_h,
                                 const StopToken* stop) {
  const double W = mesh.width, H = mesh.height;
  if (!(W + delta_w > 0 && H + delta_h > 0)) throw std::invalid_argument("polyfem fallback: an empty target");
  if (check.size() != mesh.cells.size()) throw std::invalid_argument("polyfem fallback: one check sampling per cell");
  const PolyfemNodes& nodes = solution.nodes;
  const std::size_t n = nodes.positions.size();
  const Unknowns unknowns = unknowns_of(mesh, nodes);
  std::vector<std::vector<int>> cells_of_node(n);
  for (std::size_t c = 0; c < mesh.cells.size(); ++c)
    for (int k : nodes.cell_nodes[c]) cells_of_node[k].push_back(int(c));

  // The variables are d scaled per coordinate by σ = √(K_kk / (K + L_a)_kk) (ours): the line
  // term is far stiffer than E_T on the nodes along a line, and unscaled the first steps, which
  // move every node alike, raise E_L faster than they lower E_T — the search found no step at
  // all. Jacobi's scaling evens the curvatures; without lines σ = 1 exactly, the iterates as before.
  std::vector<double> sigma(unknowns.count, 1.0);
  {
    std::vector<double> k_diag(n, 0.0);
    std::vector<Point> l_diag(n, Point{0, 0});
    for (std::size_t e = 0; e < solution.stiffness.value.size(); ++e)
      if (solution.stiffness.row[e] == solution.stiffness.col[e]) k_diag[solution.stiffness.row[e]] = solution.stiffness.value[e];
    for (std::size_t e = 0; e < solution.line_x.value.size(); ++e)
      if (solution.line_x.row[e] == solution.line_x.col[e]) l_diag[solution.line_x.row[e]].x = solution.line_x.value[e];
    for (std::size_t e = 0; e < solution.line_y.value.size(); ++e)
      if (solution.line_y.row[e] == solution.line_y.col[e]) l_diag[solution.line_y.row[e]].y = solution.line_y.value[e];
    for (std::size_t k = 0; k < n; ++k) {
      if (unknowns.x[k] >= 0 && l_diag[k].x > 0) sigma[unknowns.x[k]] = std::sqrt(k_diag[k] / (k_diag[k] + l_diag[k].x));
      if (unknowns.y[k] >= 0 && l_diag[k].y > 0) sigma[unknowns.y[k]] = std::sqrt(k_diag[k] / (k_diag[k] + l_diag[k].y));
    }
  }
  // d from the variables; the border's values fixed [eq. 12], the uniform stretch at the start.
  std::vector<Point> d(n);
  for (std::size_t k = 0; k < n; ++k) d[k] = {delta_w * nodes.positions[k].x / W, delta_h * nodes.positions[k].y / H};
  Eigen::VectorXd x(unknowns.count);
  for (std::size_t k = 0; k < n; ++k) {
    if (unknowns.x[k] >= 0) x[unknowns.x[k]] = d[k].x / sigma[unknowns.x[k]];
    if (unknowns.y[k] >= 0) x[unknowns.y[k]] = d[k].y / sigma[unknowns.y[k]];
  }
  const auto scatter = [&](const Eigen::VectorXd& v) {
    for (std::size_t k = 0; k < n; ++k) {
      if (unknowns.x[k] >= 0) d[k].x = v[unknowns.x[k]] * sigma[unknowns.x[k]];
      if (unknowns.y[k] >= 0) d[k].y = v[unknowns.y[k]] * sigma[unknowns.y[k]];
    }
  };

  std::vector<Point> kd(n);
  // kd += (M·d_x, M·d_y) restricted to the axes asked for; M by its upper triangle.
  const auto multiply = [&](const SymmetricMatrix& M, bool x, bool y) {
    for (std::size_t e = 0; e < M.value.size(); ++e) {
      const int r = M.row[e], c = M.col[e];
      const double m = M.value[e];
      if (x) kd[r].x += m * d[c].x;
      if (y) kd[r].y += m * d[c].y;
      if (r == c) continue;
      if (x) kd[c].x += m * d[r].x;
      if (y) kd[c].y += m * d[r].y;
    }
  };
  const LbfgsObjective energy = [&](const Eigen::VectorXd& v, Eigen::VectorXd& gradient) {
    scatter(v);
    std::fill(kd.begin(), kd.end(), Point{0, 0});
    multiply(solution.stiffness, true, true);
    multiply(solution.line_x, true, false);
    multiply(solution.line_y, false, true);
    double value = 0;
    gradient.resize(v.size());
    for (std::size_t k = 0; k < n; ++k) {
      value += d[k].x * kd[k].x + d[k].y * kd[k].y;
      if (unknowns.x[k] >= 0) gradient[unknowns.x[k]] = 2 * kd[k].x * sigma[unknowns.x[k]];
      if (unknowns.y[k] >= 0) gradient[unknowns.y[k]] = 2 * kd[k].y * sigma[unknowns.y[k]];
    }
    return value;
  };

  // Per-cell rollback: reset every node of a folded cell, then look again at every cell that
  // shares a reset node, until nothing folds (the previous iterate did not).
  const LbfgsRollback rollback = [&](const Eigen::VectorXd& previous, Eigen::VectorXd& trial) {
    scatter(trial);
    std::vector<int> queue(mesh.cells.size());
    for (std::size_t c = 0; c < queue.size(); ++c) queue[c] = int(c);
    std::vector<char> reset(mesh.cells.size(), 0);
    int resets = 0;
    while (!queue.empty()) {
      const int c = queue.back();
      queue.pop_back();
      if (reset[c] || !polyfem_cell_folds(check[c], d)) continue;
      reset[c] = 1, ++resets;
      for (int k : nodes.cell_nodes[c]) {
        const int ux = unknowns.x[k], uy = unknowns.y[k];
        const bool changed = (ux >= 0 && trial[ux] != previous[ux]) || (uy >= 0 && trial[uy] != previous[uy]);
        if (!changed) continue;
        if (ux >= 0) trial[ux] = previous[ux], d[k].x = previous[ux] * sigma[ux];
        if (uy >= 0) trial[uy] = previous[uy], d[k].y = previous[uy] * sigma[uy];
        for (int neighbour : cells_of_node[k])
          if (!reset[neighbour]) queue.push_back(neighbour);
      }
    }
    return resets;
  };

  PolyfemFallback out;
  Eigen::VectorXd unused;
  out.start_energy = energy(x, unused);
  // 100 steps and 10 halvings: rollbacks stall the descent well before a tolerance is met (on the
  // samples' extreme aspects the energy after 100 steps is within 1 % of the one after 200, in
  // half the time: 80–360 ms, once per target). With lines 300 (ours): even scaled, the line
  // term's stiffness slows the descent, and after 100 steps the 4:1 panorama's GBVS target at
  // 9:16 was still so near the stretch that its salient cells kept their shape no better than
  // the rest (after 300: residual 0.57 against 0.69).
  const bool lines = !solution.line_x.value.empty() || !solution.line_y.value.empty();
  const LbfgsResult result = minimize_lbfgs_with_rollback(
      x, energy, rollback, {.max_iterations = lines ? 300 : 100, .max_halvings = 10}, stop);
  out.energy = result.energy, out.iterations = result.iterations, out.rollbacks = result.rollbacks;
  out.converged = result.converged;
  scatter(x);
  out.displacement = d;
  return out;
}

}  // namespace zoomwarp::warp
