#include "warp/methods/mp/mp_solve.h"

#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <Eigen/SparseLU>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <iterator>
#include <utility>

namespace zoomwarp::warp {

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;
constexpr double kInf = std::numeric_limits<double>::infinity();
// A penalty stage only has to hand a good start to the next one (ours): it stops at a relative
// decrease below this, the final run at 1e-12 (METHODS §1).
constexpr double kStageTolerance = 1e-4;
// The shape continuation gives up below this stage (of the way from the stretch to eq. 3); one
// Newton run takes at most kRunSteps steps, one solve kSolveSteps in all (ours: bounded time —
// the samples take ≤ 250).
constexpr double kLeastShapeStage = 1.0 / 1024;
constexpr int kRunSteps = 100, kSolveSteps = 1000;
// Step 6 tries this many lower object scales, the last the fit scale (ours).
constexpr int kScaleSteps = 3;
// Step 7 lets the objects' shape go toward the stretch in this many steps, the last all the way (ours).
constexpr int kGiveWaySteps = 3;
// A result is torn (ours, issue 41) when a triangle keeps less than this share of its area under
// the uniform stretch: squeezed twenty times beyond the stretch, it shows as a crease through
// whatever it covers. eq. 10 prices it at l² per edge; with the fold barrier at ε = 1 a rigid
// solve ended with triangles beside held lines at 10⁻⁵ of their area (boats_lake_sunset.jpg at
// 360×640: salient anisotropy p99 27 639). ε (mp_solve.h) is now chosen so that the samples
// keep every triangle above this share; steps 6–7 handle the cases it cannot.
constexpr double kLeastAreaShare = 0.05;

bool torn(const MpSolution& s) { return s.least_area_share < kLeastAreaShare; }
// The fold barrier's weight in the shape continuation's stages, over ε (ours): at ε = 1 the stretch
// energy squeezed some triangles nearly flat (area ratio ~1e-4 on the samples), and the next
// stage's change of the objects' map then folds them at any step size; ×30 keeps them open. The
// last run (eq. 3) has ε, so the result minimises the same energy as every other run.
constexpr double kStageBarrier = 30;

// Which borders a source point lies on. The precompute puts boundary vertices exactly on the
// rectangle; the tolerance only absorbs rounding in its arithmetic.
struct Borders {
  bool left = false, right = false, top = false, bottom = false;
};
Borders borders_of(const Point& p, double w, double h) {
  const double eps = 1e-9 * (w + h);
  return {std::abs(p.x) <= eps, std::abs(p.x - w) <= eps, std::abs(p.y) <= eps, std::abs(p.y - h) <= eps};
}

// The unknowns of one Newton run. Every vertex coordinate is either one variable, fixed, or (in
// the hard parametrization) its object pole's coordinate plus the constant z·(P_i − P_O) of eq. 3
// — so ∂Q_i/∂(variable) is 1 in every case and the chain rule onto the pole is a scatter-add.
struct Layout {
  bool hard = false;
  // Per object, its map in the hard parametrization: Q_i = Q_O + diag(scale)(P_i − P_O); the
  // Problem's object_scale is eq. 3, anything else a stage of the shape continuation.
  std::vector<Point> scale;
  std::vector<std::array<int, 2>> vertex_var;  // variable index per coordinate, −1: fixed
  std::vector<std::array<int, 2>> pole_var;
  std::vector<Point> vertex_fixed;  // the value of a fixed vertex coordinate
  std::vector<Point> pole_fixed;
  int size = 0;
};

// What one solve shares between its Newton runs.
struct Problem {
  const MpModel* model = nullptr;
  double tw = 0, th = 0, z = 1, line_weight = 0;
  // Per object, the diagonal of its map under eq. 3: (z, z), or (ours) W'/W across an object
  // touching the left and the right border, H'/H across one touching the top and the bottom.
  std::vector<Point> object_scale;
  std::vector<int> object_of;        // per vertex: its object or −1
  std::vector<MpEdge> edges;         // those with ends in two different objects or outside objects
  std::vector<double> line_length;   // L_k, source length of each line (the line term's floor)
  double barrier = 0;                // ε of the fold barrier
  double rotation_weight = 0;        // ρ of the rotation term
  std::vector<double> stretch_area;  // per triangle, its area under the uniform stretch
};

// Positions of every vertex and pole for the variables X.
void positions(const Problem& pb, const Layout& lay, const Eigen::VectorXd& x, std::vector<Point>& q,
               std::vector<Point>& poles) {
  const MpModel& m = *pb.model;
  poles.resize(m.objects.size());
  for (size_t o = 0; o < m.objects.size(); ++o) {
    const auto& v = lay.pole_var[o];
    poles[o] = {v[0] >= 0 ? x[v[0]] : lay.pole_fixed[o].x, v[1] >= 0 ? x[v[1]] : lay.pole_fixed[o].y};
  }
  q.resize(m.mesh.vertices.size());
  for (size_t i = 0; i < q.size(); ++i) {
    const int o = pb.object_of[i];
    if (lay.hard && o >= 0) {  // [Guo09 eq. 3], rotation 0
      const Point& p = m.mesh.vertices[i];
      const Point& po = m.objects[o].pole;
      q[i] = {poles[o].x + lay.scale[o].x * (p.x - po.x), poles[o].y + lay.scale[o].y * (p.y - po.y)};
    } else {
      const auto& v = lay.vertex_var[i];
      q[i] = {v[0] >= 0 ? x[v[0]] : lay.vertex_fixed[i].x, v[1] >= 0 ? x[v[1]] : lay.vertex_fixed[i].y};
    }
  }
}

// Adds an element's gradient and (lower-triangle) Hessian over k coordinates to the system,
// dropping fixed coordinates. Triplets are emitted whatever their value so that every iteration
// has the same sparsity pattern (the factorisation's symbolic analysis is done once).
template <int K>
void scatter(const std::array<int, K>& var, const Eigen::Matrix<double, K, 1>& g, const Eigen::Matrix<double, K, K>& h,
             Eigen::VectorXd* grad, Triplets* hess) {
  for (int a = 0; a < K; ++a) {
    if (var[a] < 0) continue;
    if (grad) (*grad)[var[a]] += g[a];
    if (!hess) continue;
    for (int b = 0; b < K; ++b) {
      if (var[b] < 0 || var[b] > var[a]) continue;
      hess->emplace_back(var[a], var[b], h(a, b));
    }
  }
}

// E = Σ_e f_e + λ·E_line + the fold barrier + μ·(rigidity penalty); with grad/hess also ∇E and
// the projected Hessian (triplets, lower triangle).
double evaluate(const Problem& pb, const Layout& lay, const Eigen::VectorXd& x, double mu, Eigen::VectorXd* grad,
                Triplets* hess) {
  const MpModel& m = *pb.model;
  std::vector<Point> q, poles;
  positions(pb, lay, x, q, poles);
  if (grad) grad->setZero(lay.size);
  if (hess) hess->clear();
  double e = 0;

  // Stretch toward the ideal lengths [Guo09 eq. 10].
  for (const MpEdge& edge : pb.edges) {
    const Point d{q[edge.a].x - q[edge.b].x, q[edge.a].y - q[edge.b].y};
    e += mp_edge_energy(d, edge.length);
    if (!grad && !hess) continue;
    const Point g = mp_edge_gradient(d, edge.length);
    const MpSym2 h = mp_edge_hessian(d, edge.length);
    Eigen::Matrix<double, 4, 1> ge;
    ge << g.x, g.y, -g.x, -g.y;
    Eigen::Matrix2d he;
    he << h.xx, h.xy, h.xy, h.yy;
    Eigen::Matrix4d H;
    H << he, -he, -he, he;
    const auto& va = lay.vertex_var[edge.a];
    const auto& vb = lay.vertex_var[edge.b];
    scatter<4>({va[0], va[1], vb[0], vb[1]}, ge, H, grad, hess);
  }

  // Lines (cross-product form of eq. 7): r = cross(B − A, P − A)/ℓ for every point P between
  // the ends A and B, each a barycentric combination of mesh vertices (ours, issue 30: the whole
  // line, not only its chains), Gauss–Newton Hessian 2λJJᵀ. ℓ = |B − A| clamped to
  // [10⁻³ L, L], L the source length: r is at least P's distance from the warped chord in target
  // pixels, what a viewer sees. With ℓ = L always, as before, r shrank with the line: a line in a
  // background squeezed to 5 % kept 5 % of its weight and bent 5.5 px (bridge_cables_horizon.jpg,
  // 360×640). ℓ = |B − A| for a stretched line too weakened it: a piece of
  // interior_wine_djembe_tall.jpg with GBVS at 3:1 bent 1.2 px instead of 0.78. ℓ is a constant
  // where clamped.
  if (pb.line_weight > 0) {
    for (size_t k = 0; k < m.lines.size(); ++k) {
      const auto& points = m.lines[k].points;
      const MpLinePoint &first = points.front(), &last = points.back();
      const Point A = position(first, q), B = position(last, q);
      const double ex = B.x - A.x, ey = B.y - A.y;
      const double chord = std::hypot(ex, ey), source = pb.line_length[k];
      const double L = std::clamp(chord, 1e-3 * source, source);
      for (size_t c = 1; c + 1 < points.size(); ++c) {
        const Point P = position(points[c], q);
        const double wx = P.x - A.x, wy = P.y - A.y;
        const double cross = ex * wy - ey * wx, r = cross / L;
        e += pb.line_weight * r * r;
        if (!grad && !hess) continue;
        // ∂r over P, A and B (they sum to 0: translation invariance), onto their triangles'
        // vertices by the weights; a vertex of weight 0 (a mesh vertex's other two) is left out,
        // the same ones at every step, so the sparsity pattern stays fixed. ∂|B − A|/∂B = (B − A)/|B − A|
        // adds −cross·(B − A)/|B − A|³ to ∂r/∂B and its opposite to ∂r/∂A.
        const double k3 = L == chord ? cross / (L * L * L) : 0;
        const Point dP{-ey / L, ex / L}, dA{(ey - wy) / L + k3 * ex, (wx - ex) / L + k3 * ey},
            dB{wy / L - k3 * ex, -wx / L - k3 * ey};
        std::array<int, 18> var;
        Eigen::Matrix<double, 18, 1> J;
        int at = 0;
        for (const auto& [point, d] : {std::pair{&points[c], dP}, std::pair{&first, dA}, std::pair{&last, dB}})
          for (int j = 0; j < 3; ++j, at += 2) {
            const auto& v = lay.vertex_var[point->vertices[j]];
            const bool held = point->weights[j] != 0;
            var[at] = held ? v[0] : -1, var[at + 1] = held ? v[1] : -1;
            J[at] = point->weights[j] * d.x, J[at + 1] = point->weights[j] * d.y;
          }
        const Eigen::Matrix<double, 18, 1> g = 2 * pb.line_weight * r * J;
        const Eigen::Matrix<double, 18, 18> h = 2 * pb.line_weight * J * J.transpose();
        scatter<18>(var, g, h, grad, hess);
      }
    }
  }

  // The fold barrier (ours): ε·A⁰(r − 1 − log r), r = A/A⁰, A⁰ the triangle's area under the
  // uniform stretch. The fold-free line search alone stalls where E_l's descent points across a
  // fold (nothing in eq. 10 resists a collapsing triangle: its α_max shrinks tenfold per step);
  // this term grows without bound as r → 0 and is 0 with zero gradient at r = 1, so the identity
  // and the uniform stretch stay exact minimisers. Hessian: its convex part b''(A)·∇A∇Aᵀ (the
  // b'(A)·∇²A part is indefinite and dropped, keeping the assembled Hessian PSD).
  if (pb.barrier > 0) {
    const auto& tris = m.mesh.triangles;
    for (size_t t = 0; t < tris.size(); ++t) {
      const Point &a = q[tris[t][0]], &b = q[tris[t][1]], &c = q[tris[t][2]];
      const double area = 0.5 * signed_area2(a, b, c), a0 = pb.stretch_area[t];
      if (area <= 0) return kInf;  // only ever met by a trial point of a step
      const double r = area / a0;
      e += pb.barrier * a0 * (r - 1 - std::log(r));
      if (!grad && !hess) continue;
      Eigen::Matrix<double, 6, 1> dA;
      dA << 0.5 * (b.y - c.y), 0.5 * (c.x - b.x), 0.5 * (c.y - a.y), 0.5 * (a.x - c.x), 0.5 * (a.y - b.y),
          0.5 * (b.x - a.x);
      const Eigen::Matrix<double, 6, 1> g = pb.barrier * (1 - 1 / r) * dA;
      const Eigen::Matrix<double, 6, 6> h = (pb.barrier / (a0 * r * r)) * dA * dA.transpose();
      const auto &va = lay.vertex_var[tris[t][0]], &vb = lay.vertex_var[tris[t][1]], &vc = lay.vertex_var[tris[t][2]];
      scatter<6>({va[0], va[1], vb[0], vb[1], vc[0], vc[1]}, g, h, grad, hess);
    }
  }

  // The rotation term (ours): ρ·Σ_t A⁰_t·r_t², r_t = A10 − A01 of the triangle's affine map A
  // (source → target), the antisymmetric part that the closest rotation's angle grows with:
  // θ = atan2(A10 − A01, A00 + A11). Linear in the positions, so its Hessian 2ρA⁰JJᵀ is exact;
  // 0 with zero gradient at the identity and at the uniform stretch (A diagonal). Triangles
  // inside one object are skipped (eq. 3 has no rotation).
  if (pb.rotation_weight > 0) {
    const auto& tris = m.mesh.triangles;
    const auto& src = m.mesh.vertices;
    for (size_t t = 0; t < tris.size(); ++t) {
      const int i0 = tris[t][0], i1 = tris[t][1], i2 = tris[t][2];
      if (pb.object_of[i0] >= 0 && pb.object_of[i0] == pb.object_of[i1] && pb.object_of[i0] == pb.object_of[i2])
        continue;
      const double s00 = src[i1].x - src[i0].x, s01 = src[i2].x - src[i0].x;
      const double s10 = src[i1].y - src[i0].y, s11 = src[i2].y - src[i0].y;
      const double det = s00 * s11 - s01 * s10, a0 = 0.5 * det;
      // ∂r over (Q0.x, Q0.y, Q1.x, Q1.y, Q2.x, Q2.y).
      Eigen::Matrix<double, 6, 1> J;
      J << s00 - s01, s10 - s11, s01, s11, -s00, -s10;
      J /= det;
      const double r = J[0] * q[i0].x + J[1] * q[i0].y + J[2] * q[i1].x + J[3] * q[i1].y + J[4] * q[i2].x +
                       J[5] * q[i2].y;
      e += pb.rotation_weight * a0 * r * r;
      if (!grad && !hess) continue;
      const Eigen::Matrix<double, 6, 1> g = 2 * pb.rotation_weight * a0 * r * J;
      const Eigen::Matrix<double, 6, 6> h = 2 * pb.rotation_weight * a0 * J * J.transpose();
      const auto &va = lay.vertex_var[i0], &vb = lay.vertex_var[i1], &vc = lay.vertex_var[i2];
      scatter<6>({va[0], va[1], vb[0], vb[1], vc[0], vc[1]}, g, h, grad, hess);
    }
  }

  // Rigidity as a penalty (the continuation's stages; the hard parametrization needs none).
  if (mu > 0 && !lay.hard) {
    for (size_t i = 0; i < q.size(); ++i) {
      const int o = pb.object_of[i];
      if (o < 0) continue;
      const Point& p = m.mesh.vertices[i];
      const Point& po = m.objects[o].pole;
      const Point& s = pb.object_scale[o];
      const double r[2] = {q[i].x - poles[o].x - s.x * (p.x - po.x), q[i].y - poles[o].y - s.y * (p.y - po.y)};
      for (int c = 0; c < 2; ++c) {
        e += mu * r[c] * r[c];
        if (!grad && !hess) continue;
        Eigen::Vector2d g(2 * mu * r[c], -2 * mu * r[c]);
        Eigen::Matrix2d h;
        h << 2 * mu, -2 * mu, -2 * mu, 2 * mu;
        scatter<2>({lay.vertex_var[i][c], lay.pole_var[o][c]}, g, h, grad, hess);
      }
    }
  }
  return e;
}

// The largest step before some triangle's signed area reaches 0: each area is a quadratic in α
// along the direction; the smallest positive root over all triangles (∞ if none).
double max_fold_free_step(const Problem& pb, const Layout& lay, const Eigen::VectorXd& x, const Eigen::VectorXd& dx) {
  std::vector<Point> q, poles, q1, poles1;
  positions(pb, lay, x, q, poles);
  positions(pb, lay, x + dx, q1, poles1);
  double best = kInf;
  for (const Triangle& t : pb.model->mesh.triangles) {
    const Point& a = q[t[0]];
    const Point e1{q[t[1]].x - a.x, q[t[1]].y - a.y}, e2{q[t[2]].x - a.x, q[t[2]].y - a.y};
    const Point da{q1[t[0]].x - a.x, q1[t[0]].y - a.y};
    const Point f1{q1[t[1]].x - q[t[1]].x - da.x, q1[t[1]].y - q[t[1]].y - da.y};
    const Point f2{q1[t[2]].x - q[t[2]].x - da.x, q1[t[2]].y - q[t[2]].y - da.y};
    auto cross = [](const Point& u, const Point& v) { return u.x * v.y - u.y * v.x; };
    const double c0 = cross(e1, e2), c1 = cross(e1, f2) + cross(f1, e2), c2 = cross(f1, f2);
    // Smallest positive root of c2·α² + c1·α + c0 (c0 > 0 on a fold-free mesh).
    double root = kInf;
    if (std::abs(c2) <= 1e-14 * (std::abs(c1) + std::abs(c0))) {
      if (c1 < 0) root = -c0 / c1;
    } else {
      const double disc = c1 * c1 - 4 * c2 * c0;
      if (disc >= 0) {
        const double s = std::sqrt(disc);
        // The cancellation-free pair of roots.
        const double qq = -0.5 * (c1 + (c1 >= 0 ? s : -s));
        for (double r : {qq / c2, qq != 0 ? c0 / qq : kInf})
          if (r > 0) root = std::min(root, r);
      }
    }
    best = std::min(best, root);
  }
  return best;
}

int count_folds(const Mesh& mesh, const std::vector<Point>& q) {
  int folds = 0;
  for (const Triangle& t : mesh.triangles)
    if (signed_area2(q[t[0]], q[t[1]], q[t[2]]) <= 0) ++folds;
  return folds;
}

// The Newton system of the runs that share one layout's variables (the shape continuation's
// stages and the final run; the penalty stages): its pattern, symbolic analysis and where each
// triplet lands, computed by the first run and reused by the rest (ours: the symbolic analysis
// was a tenth of a solve).
struct NewtonSystem {
  Eigen::SparseMatrix<double> H;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  std::vector<int> slots;  // per triplet, its index in H's values
};

// Newton [Guo09 §3.4.2] with the projected Hessian and the fold-free Armijo line search; returns
// the steps taken and appends the energies to `history`.
int newton(const Problem& pb, const Layout& lay, Eigen::VectorXd& x, double mu, double rel_tol, int max_steps,
           const StopToken* stop, NewtonSystem& system, std::vector<double>& history) {
  const double grad_tol = 1e-7 * (pb.tw + pb.th);
  Eigen::VectorXd g;
  Triplets trips;
  auto& [H, ldlt, slots] = system;
  double e = evaluate(pb, lay, x, mu, &g, &trips);
  history.push_back(e);
  int steps = 0;
  for (; steps < max_steps; ++steps) {
    if (lay.size == 0 || g.lpNorm<Eigen::Infinity>() < grad_tol) break;
    if (stop) stop->check();
    // 1e-9·trace/n on the diagonal: the projection may leave null directions (e.g. a vertex
    // whose edges are all compressed), which the factorisation must not meet.
    double trace = 0;
    for (const auto& t : trips)
      if (t.row() == t.col()) trace += t.value();
    const double reg = std::max(1e-9 * trace / lay.size, 1e-300);
    for (int i = 0; i < lay.size; ++i) trips.emplace_back(i, i, reg);
    if (slots.size() != trips.size()) {
      // First step: the pattern, its symbolic analysis, and where each triplet lands in it —
      // evaluate() emits the same triplets in the same order every time for one layout's
      // variables, so later steps add values into place instead of sorting triplets again.
      H.resize(lay.size, lay.size);
      H.setFromTriplets(trips.begin(), trips.end());
      slots.clear();
      ldlt.analyzePattern(H);
      slots.reserve(trips.size());
      for (const auto& t : trips) {
        const int* begin = H.innerIndexPtr() + H.outerIndexPtr()[t.col()];
        const int* end = H.innerIndexPtr() + H.outerIndexPtr()[t.col() + 1];
        slots.push_back(static_cast<int>(std::lower_bound(begin, end, t.row()) - H.innerIndexPtr()));
      }
    } else {
      std::fill(H.valuePtr(), H.valuePtr() + H.nonZeros(), 0.0);
      for (size_t k = 0; k < trips.size(); ++k) H.valuePtr()[slots[k]] += trips[k].value();
    }
    ldlt.factorize(H);
    if (ldlt.info() != Eigen::Success) break;
    const Eigen::VectorXd dx = ldlt.solve(-g);
    const double slope = g.dot(dx);
    if (!(slope < 0)) break;
    double alpha = std::min(1.0, 0.9 * max_fold_free_step(pb, lay, x, dx));
    bool accepted = false;
    double e_new = e;
    for (int halving = 0; halving <= 30; ++halving, alpha *= 0.5) {
      e_new = evaluate(pb, lay, x + alpha * dx, mu, nullptr, nullptr);
      if (e_new < e && e_new <= e + 1e-4 * alpha * slope) {
        accepted = true;
        break;
      }
    }
    if (!accepted) break;
    x += alpha * dx;
    history.push_back(e_new);
    const double decrease = (e - e_new) / e;
    e = evaluate(pb, lay, x, mu, &g, &trips);
    if (decrease < rel_tol) {
      ++steps;
      break;
    }
  }
  return steps;
}

// The layout of one run: hard (eq. 3 substituted) or penalty (object vertices free), with the
// boundary of eq. 1.
Layout make_layout(const Problem& pb, bool hard, const std::vector<Point>& scale) {
  const MpModel& m = *pb.model;
  const size_t n = m.mesh.vertices.size(), no = m.objects.size();
  Layout lay;
  lay.hard = hard;
  lay.scale = scale;
  lay.vertex_var.assign(n, {-1, -1});
  lay.pole_var.assign(no, {-1, -1});
  lay.vertex_fixed.assign(n, {});
  lay.pole_fixed.assign(no, {});
  // Poles: an object touching a border pins that coordinate so that its border vertices land on
  // the border under eq. 3 (on two opposite borders both pins agree: its scale across them is the
  // target's, object_scale).
  for (size_t o = 0; o < no; ++o) {
    Borders touch;
    for (int i : m.objects[o].vertices) {
      const Borders b = borders_of(m.mesh.vertices[i], m.width, m.height);
      touch.left |= b.left, touch.right |= b.right, touch.top |= b.top, touch.bottom |= b.bottom;
    }
    const Point& po = m.objects[o].pole;
    if (touch.left) lay.pole_fixed[o].x = scale[o].x * po.x;
    if (touch.right && !touch.left) lay.pole_fixed[o].x = pb.tw - scale[o].x * (m.width - po.x);
    if (touch.top) lay.pole_fixed[o].y = scale[o].y * po.y;
    if (touch.bottom && !touch.top) lay.pole_fixed[o].y = pb.th - scale[o].y * (m.height - po.y);
    if (!touch.left && !touch.right) lay.pole_var[o][0] = lay.size++;
    if (!touch.top && !touch.bottom) lay.pole_var[o][1] = lay.size++;
  }
  for (size_t i = 0; i < n; ++i) {
    const int o = pb.object_of[i];
    if (hard && o >= 0) {
      lay.vertex_var[i] = lay.pole_var[o];
      continue;
    }
    const Borders b = borders_of(m.mesh.vertices[i], m.width, m.height);
    if (b.left || b.right)
      lay.vertex_fixed[i].x = b.left ? 0 : pb.tw;
    else
      lay.vertex_var[i][0] = lay.size++;
    if (b.top || b.bottom)
      lay.vertex_fixed[i].y = b.top ? 0 : pb.th;
    else
      lay.vertex_var[i][1] = lay.size++;
  }
  return lay;
}

// Variables of `lay` holding the given vertex and pole positions (free coordinates only; in the
// hard layout an object vertex has no variables of its own).
Eigen::VectorXd pack(const Problem& pb, const Layout& lay, const std::vector<Point>& q,
                     const std::vector<Point>& poles) {
  Eigen::VectorXd x(lay.size);
  for (size_t o = 0; o < poles.size(); ++o) {
    if (lay.pole_var[o][0] >= 0) x[lay.pole_var[o][0]] = poles[o].x;
    if (lay.pole_var[o][1] >= 0) x[lay.pole_var[o][1]] = poles[o].y;
  }
  for (size_t i = 0; i < q.size(); ++i) {
    if (lay.hard && pb.object_of[i] >= 0) continue;
    if (lay.vertex_var[i][0] >= 0) x[lay.vertex_var[i][0]] = q[i].x;
    if (lay.vertex_var[i][1] >= 0) x[lay.vertex_var[i][1]] = q[i].y;
  }
  return x;
}

// The rigid start's mesh around its objects (ours): a field given on the object vertices, filled
// in on the rest — positions, or a displacement (zero at the corners and across the border).
// Border vertices outside objects: along their side, piecewise linear in the source coordinate
// between the corners and the objects' border vertices (so the side stays in order whenever the
// objects are), the normal coordinate on the side (eq. 1). The rest: Floater's mean value
// coordinates [Floater03] on the uniformly stretched mesh — positive weights that reproduce
// affine maps, so the free vertices keep the stretched mesh's shape where nothing pulls, and
// (Tutte–Floater) fold nothing while the fixed vertices are in convex position. The weights are
// factorised once per solve.
class Extension {
 public:
  explicit Extension(const Problem& pb) : pb_(pb) {
    const MpModel& m = *pb.model;
    const auto& p = m.mesh.vertices;
    const size_t n = p.size();
    sides_ = {Side{true, m.height, pb.th, 0, {}, {}}, Side{true, m.height, pb.th, pb.tw, {}, {}},
              Side{false, m.width, pb.tw, 0, {}, {}}, Side{false, m.width, pb.tw, pb.th, {}, {}}};
    std::vector<bool> fixed(n);
    for (size_t i = 0; i < n; ++i) {
      const Borders b = borders_of(p[i], m.width, m.height);
      const bool on[4] = {b.left, b.right, b.top, b.bottom};
      fixed[i] = pb.object_of[i] >= 0 || b.left || b.right || b.top || b.bottom;
      for (int k = 0; k < 4; ++k) {
        if (!on[k]) continue;
        auto& list = pb.object_of[i] >= 0 ? sides_[k].anchors : sides_[k].members;
        list.push_back(static_cast<int>(i));
      }
    }
    index_.assign(n, -1);
    for (size_t i = 0; i < n; ++i)
      if (!fixed[i]) index_[i] = free_++;
    if (free_ == 0) return;
    const double kx = pb.tw / m.width, ky = pb.th / m.height;
    Triplets trips;
    for (const Triangle& t : m.mesh.triangles) {
      for (int c = 0; c < 3; ++c) {
        const int i = t[c];
        if (index_[i] < 0) continue;
        // w_ij = (tan(θ/2) + tan(θ'/2))/|v_j − v_i|, θ, θ' the angles at v_i beside edge ij.
        const int nb[2] = {t[(c + 1) % 3], t[(c + 2) % 3]};
        const Point e[2] = {{kx * (p[nb[0]].x - p[i].x), ky * (p[nb[0]].y - p[i].y)},
                            {kx * (p[nb[1]].x - p[i].x), ky * (p[nb[1]].y - p[i].y)}};
        const double half_tan =
            std::tan(0.5 * std::atan2(e[0].x * e[1].y - e[0].y * e[1].x, e[0].x * e[1].x + e[0].y * e[1].y));
        for (int k = 0; k < 2; ++k) {
          const double w = half_tan / std::hypot(e[k].x, e[k].y);
          trips.emplace_back(index_[i], index_[i], w);
          if (index_[nb[k]] >= 0)
            trips.emplace_back(index_[i], index_[nb[k]], -w);
          else
            boundary_.push_back({index_[i], nb[k], w});
        }
      }
    }
    Eigen::SparseMatrix<double> weights(free_, free_);
    weights.setFromTriplets(trips.begin(), trips.end());
    weights.makeCompressed();
    lu_.compute(weights);
  }

  void operator()(bool displacement, std::vector<Point>& f) const {
    const auto& p = pb_.model->mesh.vertices;
    for (const Side& side : sides_) {
      auto along = [&](int i) { return side.vertical ? p[i].y : p[i].x; };
      std::vector<std::pair<double, double>> anchors{{0, 0}, {side.source_len, displacement ? 0 : side.target_len}};
      for (int i : side.anchors) anchors.emplace_back(along(i), side.vertical ? f[i].y : f[i].x);
      std::sort(anchors.begin(), anchors.end());
      const double normal = displacement ? 0 : side.normal;
      for (int i : side.members) {
        auto hi = std::upper_bound(anchors.begin(), anchors.end(), std::make_pair(along(i), kInf));
        if (hi == anchors.end()) --hi;
        const auto lo = hi == anchors.begin() ? hi : std::prev(hi);
        const double t = hi->first > lo->first ? (along(i) - lo->first) / (hi->first - lo->first) : 0;
        const double value = lo->second + t * (hi->second - lo->second);
        f[i] = side.vertical ? Point{normal, value} : Point{value, normal};
      }
    }
    if (free_ == 0) return;
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(free_, 2);
    for (const auto& b : boundary_) rhs(b.row, 0) += b.weight * f[b.vertex].x, rhs(b.row, 1) += b.weight * f[b.vertex].y;
    const Eigen::MatrixXd solved = lu_.solve(rhs);
    for (size_t i = 0; i < f.size(); ++i)
      if (index_[i] >= 0) f[i] = {solved(index_[i], 0), solved(index_[i], 1)};
  }

 private:
  struct Side {
    bool vertical;
    double source_len, target_len, normal;
    std::vector<int> anchors;  // object vertices on the side
    std::vector<int> members;  // the other vertices on it
  };
  struct BoundaryWeight {
    int row, vertex;
    double weight;
  };
  const Problem& pb_;
  std::array<Side, 4> sides_;
  std::vector<int> index_;  // per vertex, its row among the free ones or −1
  int free_ = 0;
  std::vector<BoundaryWeight> boundary_;
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu_;
};

// A free pole coordinate puts the object's bounding box where eq. 8 puts a single object in its
// band: the gaps before and after it scaled alike, (T − z·ext)/(S − ext), so it stays inside the
// rectangle (ours).
double rigid_pole(double lo, double hi, double pole, double source, double target, double z) {
  const double ext = hi - lo, room = target - z * ext;
  const double lo_target = source - ext < 1 || room < 0 ? 0.5 * room : lo * room / (source - ext);
  return lo_target + z * (pole - lo);
}

std::vector<Point> rigid_poles(const Problem& pb, const Layout& hard) {
  const MpModel& m = *pb.model;
  std::vector<Point> poles(m.objects.size());
  for (size_t o = 0; o < poles.size(); ++o) {
    const MpObject& obj = m.objects[o];
    double x0 = kInf, x1 = -kInf, y0 = kInf, y1 = -kInf;
    for (int i : obj.vertices) {
      const Point& v = m.mesh.vertices[i];
      x0 = std::min(x0, v.x), x1 = std::max(x1, v.x), y0 = std::min(y0, v.y), y1 = std::max(y1, v.y);
    }
    const Point& s = pb.object_scale[o];
    poles[o].x = hard.pole_var[o][0] < 0 ? hard.pole_fixed[o].x : rigid_pole(x0, x1, obj.pole.x, m.width, pb.tw, s.x);
    poles[o].y = hard.pole_var[o][1] < 0 ? hard.pole_fixed[o].y : rigid_pole(y0, y1, obj.pole.y, m.height, pb.th, s.y);
  }
  return poles;
}

// The rigid start (ours): every object at eq. 3 around its rigid pole, the rest extended as
// above. When it folds nothing, the hard parametrization runs from it at once, without the penalty
// continuation's six or seven runs.
std::vector<Point> rigid_start(const Problem& pb, const Extension& extend, const std::vector<Point>& poles) {
  const MpModel& m = *pb.model;
  const size_t n = m.mesh.vertices.size();
  std::vector<Point> q(n);
  for (size_t i = 0; i < n; ++i) {
    const int o = pb.object_of[i];
    if (o < 0) continue;
    const Point& p = m.mesh.vertices[i];
    const Point& po = m.objects[o].pole;
    const Point& s = pb.object_scale[o];
    q[i] = {poles[o].x + s.x * (p.x - po.x), poles[o].y + s.y * (p.y - po.y)};
  }
  extend(false, q);
  return q;
}

// The least z of the background-scale bound over the rows (rows = true: lengths across them) or
// the columns, each row's object length the sum of the objects' mesh extents on it — per object,
// from the lowest to the highest coordinate of its edges (both ends in it) crossing the row, and
// from the border for an object on it.
double extent_bound(const MpModel& model, const std::vector<int>& object_of, bool rows, double target, double beta) {
  const double source = rows ? model.width : model.height;
  const int lines = static_cast<int>(std::ceil(rows ? model.height : model.width));
  const size_t no = model.objects.size();
  std::vector<double> lo(no * lines, kInf), hi(no * lines, -kInf);
  for (const Triangle& t : model.mesh.triangles) {
    for (int c = 0; c < 3; ++c) {
      const int o = object_of[t[c]];
      if (o < 0 || object_of[t[(c + 1) % 3]] != o) continue;
      const Point &p = model.mesh.vertices[t[c]], &q = model.mesh.vertices[t[(c + 1) % 3]];
      const double a0 = std::min(rows ? p.x : p.y, rows ? q.x : q.y), a1 = std::max(rows ? p.x : p.y, rows ? q.x : q.y);
      const double b0 = std::min(rows ? p.y : p.x, rows ? q.y : q.x), b1 = std::max(rows ? p.y : p.x, rows ? q.y : q.x);
      for (int k = std::max(0, static_cast<int>(std::floor(b0))); k < lines && k <= b1; ++k) {
        lo[o * lines + k] = std::min(lo[o * lines + k], a0);
        hi[o * lines + k] = std::max(hi[o * lines + k], a1);
      }
    }
  }
  // An object on a border has its pole pinned there (eq. 1): what lies between it and that
  // border keeps scale z too, so its extent reaches the border.
  for (size_t o = 0; o < no; ++o) {
    bool low = false, high = false;
    for (int i : model.objects[o].vertices) {
      const Borders b = borders_of(model.mesh.vertices[i], model.width, model.height);
      low |= rows ? b.left : b.top, high |= rows ? b.right : b.bottom;
    }
    for (int k = 0; k < lines; ++k) {
      if (!(hi[o * lines + k] >= lo[o * lines + k])) continue;
      if (low) lo[o * lines + k] = 0;
      if (high) hi[o * lines + k] = source;
    }
  }
  double z = kInf;
  for (int k = 0; k < lines; ++k) {
    double l = 0;
    for (size_t o = 0; o < no; ++o)
      if (hi[o * lines + k] > lo[o * lines + k]) l += hi[o * lines + k] - lo[o * lines + k];
    if (l > 0) z = std::min(z, (target - beta * (target / source) * (source - l)) / l);
  }
  return z;
}


// The solve's fixed data at object scale z (step 1 or 6): the objects' maps, the edges eq. 10
// prices, the lines' source lengths, the stretch's triangle areas; the preconditions of mp_solve
// checked on the way.
Problem make_problem(const MpModel& model, double target_w, double target_h, double z, const MpSolveOptions& options) {
  if (!(model.width > 0 && model.height > 0 && target_w > 0 && target_h > 0))
    throw std::invalid_argument("mp_solve: sizes must be positive");
  const size_t n = model.mesh.vertices.size();
  Problem pb;
  pb.model = &model;
  pb.tw = target_w;
  pb.th = target_h;
  pb.line_weight = options.line_weight;
  pb.z = z;
  pb.object_of.assign(n, -1);
  for (size_t o = 0; o < model.objects.size(); ++o) {
    Borders touch;
    for (int i : model.objects[o].vertices) {
      if (i < 0 || static_cast<size_t>(i) >= n || pb.object_of[i] >= 0)
        throw std::invalid_argument("mp_solve: an object vertex out of range or in two objects");
      pb.object_of[i] = static_cast<int>(o);
      const Borders b = borders_of(model.mesh.vertices[i], model.width, model.height);
      touch.left |= b.left, touch.right |= b.right, touch.top |= b.top, touch.bottom |= b.bottom;
    }
    // Ours: between two opposite borders eq. 1 fixes the object's scale across them; z ≤ W'/W
    // (H'/H) there already (its bounding box spans the width), so the map stays a similarity
    // whenever z reaches it, and is the least stretch of it otherwise.
    pb.object_scale.push_back({touch.left && touch.right ? target_w / model.width : pb.z,
                               touch.top && touch.bottom ? target_h / model.height : pb.z});
  }
  // An edge inside one object keeps its length z·|P_i − P_j| under eq. 3: skipped [Guo09 §3.4.1].
  for (const MpEdge& e : mp_ideal_edges(model, target_w, target_h, pb.z))
    if (pb.object_of[e.a] < 0 || pb.object_of[e.a] != pb.object_of[e.b]) pb.edges.push_back(e);
  for (const MpLine& line : model.lines) {
    for (const MpLinePoint& p : line.points)
      for (int k = 0; k < 3; ++k)
        if (p.vertices[k] < 0 || static_cast<size_t>(p.vertices[k]) >= n || !std::isfinite(p.weights[k]))
          throw std::invalid_argument("mp_solve: a line point's vertex out of range or weight not finite");
    if (line.points.size() < 2) throw std::invalid_argument("mp_solve: a line needs two distinct ends");
    const Point a = position(line.points.front(), model.mesh.vertices);
    const Point b = position(line.points.back(), model.mesh.vertices);
    pb.line_length.push_back(std::hypot(b.x - a.x, b.y - a.y));
    if (!(pb.line_length.back() > 0)) throw std::invalid_argument("mp_solve: a line needs two distinct ends");
  }
  pb.barrier = options.fold_barrier;
  pb.rotation_weight = options.rotation_weight;
  for (const Triangle& t : model.mesh.triangles) {
    const double a =
        0.5 * signed_area2(model.mesh.vertices[t[0]], model.mesh.vertices[t[1]], model.mesh.vertices[t[2]]);
    if (!(a > 0)) throw std::invalid_argument("mp_solve: a source triangle is not counter-clockwise");
    pb.stretch_area.push_back(a * (target_w / model.width) * (target_h / model.height));
  }
  return pb;
}

// What the solve has done so far (its MpSolution) and the hard parametrization's Newton system,
// shared by every run of that layout.
struct Progress {
  Progress(const Problem& pb, const StopToken* stop_token) : stop(stop_token) {
    sol.object_scale = pb.z;
    sol.object_scales = pb.object_scale;
  }
  MpSolution sol;
  NewtonSystem hard_system;
  const StopToken* stop = nullptr;
  // The steps the next run may take: kRunSteps, or fewer when the solve's kSolveSteps run out.
  int budget() const { return std::clamp(kSolveSteps - sol.iterations, 0, kRunSteps); }
};

// The solution's fields at the variables x of a layout: positions, poles, energy without the
// barrier, folds, rigidity residual.
void finish(const Problem& pb, const Layout& lay, const Eigen::VectorXd& x, MpSolution& sol) {
  const MpModel& model = *pb.model;
  positions(pb, lay, x, sol.positions, sol.poles);
  sol.rigid = lay.hard;
  Problem plain = pb;
  plain.barrier = 0;
  sol.energy = evaluate(plain, lay, x, 0, nullptr, nullptr);
  sol.folds = count_folds(model.mesh, sol.positions);
  sol.least_area_share = 1;
  for (size_t t = 0; t < model.mesh.triangles.size(); ++t) {
    const Triangle& tri = model.mesh.triangles[t];
    const double area = 0.5 * signed_area2(sol.positions[tri[0]], sol.positions[tri[1]], sol.positions[tri[2]]);
    sol.least_area_share = std::min(sol.least_area_share, area / pb.stretch_area[t]);
  }
  sol.rigidity_residual = 0;
  for (size_t i = 0; i < sol.positions.size(); ++i) {
    const int o = pb.object_of[i];
    if (o < 0) continue;
    const Point& p = model.mesh.vertices[i];
    const Point& po = model.objects[o].pole;
    const Point &q = sol.positions[i], &s = pb.object_scale[o];
    sol.rigidity_residual = std::max(sol.rigidity_residual, std::hypot(q.x - sol.poles[o].x - s.x * (p.x - po.x),
                                                                       q.y - sol.poles[o].y - s.y * (p.y - po.y)));
  }
}

// Step 5: one run of the hard parametrization (eq. 3 substituted) from vertex and pole
// positions, if eq. 3 applied to them folds nothing; false (and nothing run) otherwise.
bool final_run(const Problem& pb, const Layout& hard, const std::vector<Point>& q0, const std::vector<Point>& poles0,
               Progress& run) {
  Eigen::VectorXd x = pack(pb, hard, q0, poles0);
  std::vector<Point> qh, ph;
  positions(pb, hard, x, qh, ph);
  if (count_folds(pb.model->mesh, qh) > 0) return false;
  run.sol.energy_history.emplace_back();
  run.sol.iterations +=
      newton(pb, hard, x, 0, 1e-12, run.budget(), run.stop, run.hard_system, run.sol.energy_history.back());
  finish(pb, hard, x, run.sol);
  return true;
}

// Every vertex and pole under the uniform stretch onto the target (the cold start; fold-free).
std::pair<std::vector<Point>, std::vector<Point>> uniform_stretch(const Problem& pb) {
  const MpModel& model = *pb.model;
  const double kx = pb.tw / model.width, ky = pb.th / model.height;
  std::vector<Point> q, poles;
  for (const Point& p : model.mesh.vertices) q.push_back({p.x * kx, p.y * ky});
  for (const MpObject& o : model.objects) poles.push_back({o.pole.x * kx, o.pole.y * ky});
  return {q, poles};
}

// The warm start: the nearby solution mapped affinely onto the new rectangle (orientation kept,
// the boundary exact), each pole the mean of its object's vertices (as Q_O is under eq. 3, P_O
// being the mean of the P_i). Empty when the options hold none for this mesh.
std::pair<std::vector<Point>, std::vector<Point>> warm_start(const Problem& pb, const MpSolveOptions& options) {
  const MpModel& model = *pb.model;
  const size_t n = model.mesh.vertices.size();
  if (options.warm_start.empty() || options.warm_start.size() != n || !(options.warm_width > 0) ||
      !(options.warm_height > 0))
    return {};
  const double kx = pb.tw / options.warm_width, ky = pb.th / options.warm_height;
  std::vector<Point> q(n);
  for (size_t i = 0; i < n; ++i) q[i] = {options.warm_start[i].x * kx, options.warm_start[i].y * ky};
  std::vector<Point> poles(model.objects.size());
  for (size_t o = 0; o < model.objects.size(); ++o) {
    for (int i : model.objects[o].vertices) poles[o].x += q[i].x, poles[o].y += q[i].y;
    const double k = 1.0 / std::max<size_t>(1, model.objects[o].vertices.size());
    poles[o] = {poles[o].x * k, poles[o].y * k};
  }
  return {q, poles};
}

// Step 3, the shape continuation: the objects' map goes from the uniform stretch diag(W'/W, H'/H)
// to eq. 3's z·I in stages, each a Newton run of the hard parametrization with that map (poles and
// the rest free, the barrier holding every triangle open); a stage whose map would fold the mesh
// as it stands is halved. Its last stage is eq. 3 itself, the final run (step 5). False when a
// stage falls below kLeastShapeStage or the steps run out.
bool shape_continuation(const Problem& pb, const Extension& extend, Progress& run) {
  const MpModel& model = *pb.model;
  const size_t n = model.mesh.vertices.size();
  const Point stretch{pb.tw / model.width, pb.th / model.height};
  auto layout_at = [&](double t) {
    std::vector<Point> scale;
    for (const Point& s : pb.object_scale)
      scale.push_back({stretch.x + t * (s.x - stretch.x), stretch.y + t * (s.y - stretch.y)});
    return make_layout(pb, true, scale);
  };
  Layout lay = layout_at(0);
  auto [qs, ps] = uniform_stretch(pb);
  Eigen::VectorXd x = pack(pb, lay, qs, ps);
  Problem staged = pb;
  staged.barrier = kStageBarrier * pb.barrier;
  // Without the rotation term: a stage only hands a fold-free start to the next, and the term
  // held the rim against the objects' changing map (interior_wine_djembe_tall.jpg with GBVS at
  // 3:1: every stage stalled, and the penalty fallback ended 0.08 px from rigid).
  staged.rotation_weight = 0;
  double t = 0, dt = 0.25;
  while (t < 1) {
    if (dt < kLeastShapeStage || run.budget() == 0) return false;
    const double t1 = std::min(1.0, t + dt);
    const Layout next = layout_at(t1);
    positions(pb, lay, x, qs, ps);
    Eigen::VectorXd x1 = pack(pb, next, qs, ps);
    std::vector<Point> q1, p1;
    positions(pb, next, x1, q1, p1);
    // The rest moves along with the objects (extended as in the rigid start).
    std::vector<Point> delta(n);
    for (size_t i = 0; i < n; ++i)
      if (pb.object_of[i] >= 0) delta[i] = {q1[i].x - qs[i].x, q1[i].y - qs[i].y};
    extend(true, delta);
    for (size_t i = 0; i < n; ++i)
      if (pb.object_of[i] < 0) q1[i] = {qs[i].x + delta[i].x, qs[i].y + delta[i].y};
    x1 = pack(pb, next, q1, p1);
    if (count_folds(model.mesh, q1) > 0) {
      dt *= 0.5;
      continue;
    }
    if (t1 == 1) return final_run(pb, next, q1, p1, run);
    run.sol.energy_history.emplace_back();
    run.sol.iterations +=
        newton(staged, next, x1, 0, kStageTolerance, run.budget(), run.stop, run.hard_system, run.sol.energy_history.back());
    t = t1, lay = next, x = x1, dt *= 2;
  }
  return false;
}

// Step 4, rigidity by a penalty, from the uniform stretch: μ up 10× per stage (more stalls the
// line search against folds). Once the objects are within `rigid_enough` px of eq. 3 (ours), the
// remaining stages would only creep toward what the hard parametrization reaches in a few steps:
// the final run (step 5) then; if that folds, the stages go on, and the μ = 1e6 result stands.
void penalty_continuation(const Problem& pb, const Layout& hard, double rigid_enough, Progress& run) {
  const Layout soft = make_layout(pb, false, pb.object_scale);
  NewtonSystem soft_system;
  const auto [q0, p0] = uniform_stretch(pb);
  Eigen::VectorXd x = pack(pb, soft, q0, p0);
  for (double mu = 1; mu <= 1e6; mu *= 10) {
    run.sol.energy_history.emplace_back();
    run.sol.iterations +=
        newton(pb, soft, x, mu, kStageTolerance, run.budget(), run.stop, soft_system, run.sol.energy_history.back());
    finish(pb, soft, x, run.sol);
    if (run.sol.rigidity_residual <= rigid_enough || mu == 1e6) {
      const std::vector<Point> qs = run.sol.positions, ps = run.sol.poles;
      if (final_run(pb, hard, qs, ps, run)) return;
    }
  }
}

// Steps 2 and 3 in the hard layout `hard` of pb: the rigid start, and if that folds, the shape
// continuation. True when either ended rigid (run.sol then holds the result).
bool rigid_solve(const Problem& pb, const Layout& hard, Progress& run) {
  const std::vector<Point> poles = rigid_poles(pb, hard);
  const Extension extend(pb);
  return final_run(pb, hard, rigid_start(pb, extend, poles), poles, run) || shape_continuation(pb, extend, run);
}

// Step 6 (ours): eq. 3 was not reached at z without tearing — every path from the stretch
// stalled where the objects at z leave the background too little room to bend into without
// collapsing, and the penalty result (`failed`) is neither rigid nor open
// (samples/planks_by_the_water.jpg at 9:16: 19 px from eq. 3, triangles at 1e-11 of their area,
// lines bent 6 px); or (issue 41) it is rigid but torn, a triangle squeezed below kLeastAreaShare
// of its stretched area. z then steps toward the fit scale z_fit = min(W'/W, H'/H), where the
// objects shrink at least as much as the stretch in both directions, halving the distance each
// time (kScaleSteps, the last z_fit itself), each step taking steps 2–3 from the stretch with its
// own step budget. The first that ends rigid and untorn stands.
//
// Step 7 (ours, issue 41): torn even at z_fit, the objects give way. A held line that crosses an
// object cannot keep its slope in the object (a similarity) and in a background stretched by
// another ratio unless the triangles where they meet collapse (interior_wine_djembe_tall.jpg with
// GBVS at 16:9 and 3:1: a triangle at 4·10⁻⁸ of its area under z_fit). Each object's map then
// goes from eq. 3's toward the stretch, s = s_stretch + k·(s_fit − s_stretch), k = 1/2, 1/4, 0 —
// at k = 0 the objects follow the stretch as every line does, so nothing is left to collapse. The
// first untorn result stands, object_shape_kept = k saying how much of eq. 3's shape is kept; if
// none is untorn, the least torn rigid result of steps 6–7, else `failed`.
MpSolution lowered_scale_solve(const MpModel& model, double target_w, double target_h, const MpSolveOptions& options,
                               MpSolution failed) {
  const Point stretch{target_w / model.width, target_h / model.height};
  const double z_fit = std::min(stretch.x, stretch.y);
  const double z = failed.object_scale;
  int iterations = failed.iterations;
  std::optional<MpSolution> best;  // the least torn rigid result so far
  if (failed.rigid) best = std::move(failed);
  // One solve at object scale zk with the objects' maps kept to a share `kept` of eq. 3's shape.
  auto attempt = [&](double zk, double kept) {
    Problem pb = make_problem(model, target_w, target_h, zk, options);
    for (Point& s : pb.object_scale) s = {stretch.x + kept * (s.x - stretch.x), stretch.y + kept * (s.y - stretch.y)};
    Progress run(pb, options.stop);
    const bool rigid = rigid_solve(pb, make_layout(pb, true, pb.object_scale), run);
    iterations += run.sol.iterations;
    run.sol.object_shape_kept = kept;
    run.sol.rigid = rigid && kept == 1;  // eq. 3 holds only with the whole shape kept
    if (rigid && !torn(run.sol)) return std::optional<MpSolution>(std::move(run.sol));
    if (rigid && (!best || run.sol.least_area_share > best->least_area_share)) best = std::move(run.sol);
    return std::optional<MpSolution>();
  };
  std::optional<MpSolution> out;
  for (int k = 1; !out && z > z_fit && k <= kScaleSteps; ++k)  // step 6
    out = attempt(k == kScaleSteps ? z_fit : z_fit + std::ldexp(z - z_fit, -k), 1);
  for (int k = 1; !out && !model.objects.empty() && k <= kGiveWaySteps; ++k)  // step 7
    out = attempt(std::min(z, z_fit), k == kGiveWaySteps ? 0 : std::ldexp(1, -k));
  MpSolution result = out ? std::move(*out) : best ? std::move(*best) : std::move(failed);
  result.iterations = iterations;
  return result;
}

}  // namespace

double mp_edge_energy(Point d, double l) {
  const double s = d.x * d.x + d.y * d.y - l * l;
  return s * s / (l * l);
}

Point mp_edge_gradient(Point d, double l) {
  // 4, not 001's 8: its sum runs over every edge twice (METHODS §1).
  const double k = 4 * (d.x * d.x + d.y * d.y - l * l) / (l * l);
  return {k * d.x, k * d.y};
}

MpSym2 mp_edge_hessian(Point d, double l) {
  // The exact Hessian (4/l²)[(|d|² − l²)I + 2ddᵀ] has eigenvalue (4/l²)(|d|² − l²) across d and
  // (4/l²)(3|d|² − l²) along it; clamping both at 0 keeps Newton's direction a descent one.
  const double d2 = d.x * d.x + d.y * d.y, l2 = l * l;
  const double across = 4 * std::max(0.0, d2 - l2) / l2, along = 4 * std::max(0.0, 3 * d2 - l2) / l2;
  if (d2 == 0) return {across, 0, across};  // u undefined; both clamped values are 0 here anyway
  const double ux = d.x * d.x / d2, uxy = d.x * d.y / d2, uy = d.y * d.y / d2;
  return {across * (1 - ux) + along * ux, (along - across) * uxy, across * (1 - uy) + along * uy};
}

double mp_object_scale(const MpModel& model, double target_w, double target_h, double beta) {
  double z = 1, area = 0;
  for (const MpObject& o : model.objects) area += o.area;
  if (area > 0) z = std::min(z, std::sqrt(target_w * target_h / area));
  for (double lr : model.row_object_length)
    if (lr > 0) z = std::min(z, (target_w - beta * (target_w / model.width) * (model.width - lr)) / lr);
  for (double lc : model.column_object_length)
    if (lc > 0) z = std::min(z, (target_h - beta * (target_h / model.height) * (model.height - lc)) / lc);
  // Each object's bounding box likewise (ours): the tables hold a row's object length, which for a
  // slanted object is shorter than its extent; eq. 3 moves the whole extent at z, and an object
  // on a border could not fit the rectangle otherwise.
  for (const MpObject& o : model.objects) {
    double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
    for (int i : o.vertices) {
      const Point& p = model.mesh.vertices[i];
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    }
    if (x1 > x0) z = std::min(z, (target_w - beta * (target_w / model.width) * (model.width - (x1 - x0))) / (x1 - x0));
    if (y1 > y0) z = std::min(z, (target_h - beta * (target_h / model.height) * (model.height - (y1 - y0))) / (y1 - y0));
  }
  // And the objects' extents on each row (column) added up (ours): the tables count the masks'
  // pixels, but an object's vertices reach past its mask, and where two objects' vertices share
  // rows that their masks do not, the tables allow a z at which eq. 3 cannot put them side by side
  // (nor, with a line through both, one above the other). From the stretch every continuation
  // then stalls as they press into each other — the synthetic picture of mp_property_test.cc with
  // GBVS at 9:16: the disc and block on the left border and the bar's top need 665 px of a 569-px
  // width on the horizon's rows at z = 1, and the solve ended 36 px from rigid.
  std::vector<int> object_of(model.mesh.vertices.size(), -1);
  for (size_t o = 0; o < model.objects.size(); ++o)
    for (int i : model.objects[o].vertices)
      if (i >= 0 && static_cast<size_t>(i) < object_of.size()) object_of[i] = static_cast<int>(o);
  z = std::min(z, extent_bound(model, object_of, true, target_w, beta));
  z = std::min(z, extent_bound(model, object_of, false, target_h, beta));
  return z;
}

std::vector<MpEdge> mp_ideal_edges(const MpModel& model, double target_w, double target_h, double z) {
  const auto& verts = model.mesh.vertices;
  auto table = [](const std::vector<double>& t, double c) {
    if (t.empty()) return 0.0;
    const int i = std::clamp(static_cast<int>(std::floor(c)), 0, static_cast<int>(t.size()) - 1);
    return t[i];
  };
  // Per-vertex scales [Guo09 eq. 8]: the row's width left after its objects, over what the
  // background had; a row almost all object (< 1 px of background) takes the plain W'/W.
  std::vector<double> sx(verts.size()), sy(verts.size());
  for (size_t i = 0; i < verts.size(); ++i) {
    const double lr = table(model.row_object_length, verts[i].y);
    const double lc = table(model.column_object_length, verts[i].x);
    sx[i] = model.width - lr < 1 ? target_w / model.width : (target_w - z * lr) / (model.width - lr);
    sy[i] = model.height - lc < 1 ? target_h / model.height : (target_h - z * lc) / (model.height - lc);
  }
  std::vector<std::pair<int, int>> pairs;
  for (const Triangle& t : model.mesh.triangles)
    for (int k = 0; k < 3; ++k) pairs.emplace_back(std::minmax(t[k], t[(k + 1) % 3]));
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::vector<MpEdge> edges;
  edges.reserve(pairs.size());
  for (auto [a, b] : pairs) {
    // [Guo09 eq. 9], the edge's scales the means of its ends'.
    const double ex = 0.5 * (sx[a] + sx[b]) * std::abs(verts[a].x - verts[b].x);
    const double ey = 0.5 * (sy[a] + sy[b]) * std::abs(verts[a].y - verts[b].y);
    edges.push_back({a, b, std::hypot(ex, ey)});
  }
  return edges;
}

MpSolution mp_solve(const MpModel& model, double target_w, double target_h, const MpSolveOptions& options) {
  const double z = mp_object_scale(model, target_w, target_h, options.beta);  // step 1
  const Problem pb = make_problem(model, target_w, target_h, z, options);
  Progress run(pb, options.stop);
  const Layout hard = make_layout(pb, true, pb.object_scale);

  if (const auto [q, poles] = warm_start(pb, options); !q.empty() && final_run(pb, hard, q, poles, run) && !torn(run.sol)) {
    run.sol.warm_started = true;
    return run.sol;
  }
  if (model.objects.empty()) {
    const auto [q, poles] = uniform_stretch(pb);
    final_run(pb, hard, q, poles, run);
    return run.sol;
  }
  if (rigid_solve(pb, hard, run)) {  // steps 2 and 3
    if (!torn(run.sol)) return run.sol;
    return lowered_scale_solve(model, target_w, target_h, options, std::move(run.sol));  // step 6
  }
  penalty_continuation(pb, hard, options.rigid_enough, run);  // step 4
  if (run.sol.rigid && !torn(run.sol)) return run.sol;
  return lowered_scale_solve(model, target_w, target_h, options, std::move(run.sol));  // step 6
}

}  // namespace zoomwarp::warp
