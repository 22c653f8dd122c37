#include "warp/icaz/shape_warp.h"

#include <Eigen/CholmodSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/Dense>
#include <Eigen/OrderingMethods>
#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <variant>

#include "warp/core/corner_point.h"
#include "warp/core/fold_blend.h"
#include "warp/core/segment_pieces.h"
#include "warp/icaz/spring_matrix.h"

namespace zoomwarp::warp {

namespace {

using SpMat = Eigen::SparseMatrix<double>;
using Triplets = std::vector<Eigen::Triplet<double>>;
using Solver = Eigen::CholmodSimplicialLLT<SpMat>;  // simplicial beats supernodal at these sizes

// One axis's factored system of the fast path, from its lower triangle (already in elimination
// order: no ordering here). A view's local fine level, a few hundred unknowns, is factored anew
// for every view: there Eigen's simplicial LLᵀ, whose symbolic analysis costs a fraction of
// CHOLMOD's, is faster (ShapeWarp construction on local submeshes of 530–780 unknowns, one or
// two factorizations: 420–570 → 360–490 µs; back-substitutions ~3 % slower); systems factored
// once and solved many times (the coarsest mesh, ~1600 unknowns; retarget-zoom's uniform mesh)
// stay with CHOLMOD.
class AxisFactor {
 public:
  static constexpr int kSmall = 1000;  // unknowns

  explicit AxisFactor(const SpMat& lower) {
    const bool factored = lower.rows() <= kSmall ? compute(factor_.emplace<Small>(), lower)
                                                 : compute(factor_.emplace<Solver>(), lower);
    if (!factored) throw std::runtime_error("could not factor the warp system");
  }

  Eigen::VectorXd solve(const Eigen::VectorXd& b) const {
    return std::visit([&](const auto& f) -> Eigen::VectorXd { return f.solve(b); }, factor_);
  }

 private:
  using Small = Eigen::SimplicialLLT<SpMat, Eigen::Lower, Eigen::NaturalOrdering<int>>;

  static bool compute(Small& f, const SpMat& lower) {
    f.compute(lower);
    return f.info() == Eigen::Success;
  }
  static bool compute(Solver& f, const SpMat& lower) {
    f.cholmod().nmethods = 1;
    f.cholmod().method[0].ordering = CHOLMOD_NATURAL;
    f.compute(lower);
    return f.info() == Eigen::Success;
  }

  std::variant<Small, Solver> factor_;
};

enum class LineKind { kHorizontal, kVertical, kOblique };

// A line constraint as the solver sees it: points along it (core/corner_point.h), start first,
// end last.
struct Line {
  std::vector<CornerPoint> points;
  LineKind kind;
};

// A point of a piece as a CornerPoint: a corner whose weight is 1 but for rounding is the vertex
// itself (a line the mesh follows is held at its vertices, as [ICAZ §4.3] holds it), and a weight
// that is 0 but for rounding is 0 (the line terms leave such corners out).
CornerPoint line_point(const Mesh& mesh, const MeshPoint& p) {
  const Triangle& t = mesh.triangles[std::size_t(p.triangle)];
  for (int k = 0; k < 3; ++k)
    if (p.barycentric[k] > 1 - 1e-9) return {{t[k], t[k], t[k]}, {1, 0, 0}};
  CornerPoint out{{t[0], t[1], t[2]}, p.barycentric};
  for (double& w : out.weights)
    if (std::abs(w) <= 1e-12) w = 0;
  return out;
}

// How many corners a line term reads of p (those of weight 0 are left out).
int corners(const CornerPoint& p) { return int(std::count_if(p.weights.begin(), p.weights.end(), [](double w) { return w != 0; })); }

// The parts of s on the mesh, each as its points in order: the ends of every piece (segment_pieces),
// which are its crossings with triangle edges; a point shared by two pieces once. A part needs
// two distinct points to constrain anything.
std::vector<std::vector<CornerPoint>> held_parts(const Mesh& mesh, const Segment& s) {
  const double length = std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
  std::vector<std::vector<CornerPoint>> parts;
  if (!(length > 0)) return parts;
  const double same = 1e-9 / std::max(1.0, length);  // in u: a nanopixel
  std::vector<std::pair<double, CornerPoint>> part;   // (u, point)
  double covered = -1;
  auto close = [&]() {
    std::sort(part.begin(), part.end(), [](const auto& p, const auto& q) { return p.first < q.first; });
    std::vector<CornerPoint> points;
    double last = -1;
    for (const auto& [u, p] : part)
      if (points.empty() || u > last + same) points.push_back(p), last = u;
    if (points.size() >= 2) parts.push_back(std::move(points));
    part.clear();
  };
  for (const SegmentPiece& piece : segment_pieces(mesh, s)) {
    if (piece.lo > covered + same) close();
    covered = std::max(covered, piece.hi);
    for (double u : {piece.lo, piece.hi}) part.emplace_back(u, line_point(mesh, piece_point(mesh, s, piece, u)));
  }
  close();
  return parts;
}

// The unit normal n of a line's orientation form ((v'_i − v'_s)·n)² [ICAZ §4.3]: fixed for
// horizontal and vertical lines, else perpendicular to the chord of its end points in `positions`.
Point line_normal(const Line& l, const std::vector<Point>& positions) {
  if (l.kind == LineKind::kHorizontal) return {0, 1};
  if (l.kind == LineKind::kVertical) return {1, 0};
  const Point s = position(l.points.front(), positions), e = position(l.points.back(), positions);
  const double dx = e.x - s.x, dy = e.y - s.y, len = std::hypot(dx, dy);
  return len > 0 ? Point{-dy / len, dx / len} : Point{0, 1};
}

// The largest distance between a vertex's positions in a and b (convergence test).
double largest_move(const std::vector<Point>& a, const std::vector<Point>& b) {
  double largest2 = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double dx = b[i].x - a[i].x, dy = b[i].y - a[i].y;
    largest2 = std::max(largest2, dx * dx + dy * dy);
  }
  return std::sqrt(largest2);
}

}  // namespace

struct ShapeWarp::Impl {
  Mesh mesh;
  std::vector<double> weights;
  double width, height;
  std::vector<Line> lines;
  // Oblique lines, or horizontal/vertical ones held between vertices: the joint path.
  bool has_oblique = false;

  // Boundary constraints: which vertices have a fixed x (left/right edge) or y (top/bottom).
  std::vector<signed char> fixed_x, fixed_y;  // 0 free, 1 at 0, 2 at the far side, 3 pinned (or in no triangle)
  bool has_pinned = false;
  // Per axis, the index of each free vertex among the free unknowns, or -1.
  std::vector<int> free_x, free_y;
  int n_free_x = 0, n_free_y = 0;

  // Fast path: one factorization per axis, and the coupling A_FC of free to fixed unknowns: the
  // fixed values x_C (0, the target size, or a pinned position) enter the RHS as −A_FC x_C.
  std::shared_ptr<const AxisFactor> solver_x, solver_y;  // the same one when the systems are equal
  std::vector<Coupling> coupling_x, coupling_y;

  void classify(const std::vector<int>& pinned) {
    const std::size_t n = mesh.vertices.size();
    fixed_x.assign(n, 0), fixed_y.assign(n, 0), free_x.assign(n, -1), free_y.assign(n, -1);
    const double eps_x = 1e-9 * std::max(1.0, width), eps_y = 1e-9 * std::max(1.0, height);
    for (std::size_t i = 0; i < n; ++i) {
      const Point& p = mesh.vertices[i];
      if (std::abs(p.x) <= eps_x) fixed_x[i] = 1;
      else if (std::abs(p.x - width) <= eps_x) fixed_x[i] = 2;
      if (std::abs(p.y) <= eps_y) fixed_y[i] = 1;
      else if (std::abs(p.y - height) <= eps_y) fixed_y[i] = 2;
    }
    for (int v : pinned) {
      if (v < 0 || std::size_t(v) >= n) throw std::invalid_argument("pinned vertex out of range");
      fixed_x[v] = fixed_y[v] = 3;
      has_pinned = true;
    }
    // A vertex in no triangle — CGAL leaves one where crossing lines meet the border outside the
    // domain — has no shape term, and no line term holds it (lines are held through triangles):
    // it stays where the start puts it, or its unknowns would make the system singular.
    std::vector<char> in_triangle(n, 0);
    for (const Triangle& t : mesh.triangles)
      for (int v : t) in_triangle[std::size_t(v)] = 1;
    for (std::size_t i = 0; i < n; ++i)
      if (!in_triangle[i]) {
        if (!fixed_x[i]) fixed_x[i] = 3;
        if (!fixed_y[i]) fixed_y[i] = 3;
      }
    std::vector<int> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = int(i);
    number_unknowns(order);
  }

  // Numbers each axis's free unknowns in `order` (a permutation of the vertices).
  void number_unknowns(const std::vector<int>& order) {
    free_x.assign(fixed_x.size(), -1), free_y.assign(fixed_y.size(), -1);
    n_free_x = n_free_y = 0;
    for (int i : order) {
      if (!fixed_x[i]) free_x[i] = n_free_x++;
      if (!fixed_y[i]) free_y[i] = n_free_y++;
    }
  }

  // The fast path's systems. Per axis, the matrix is the weighted graph Laplacian
  // Σ_f w_f Σ_e (e_i − e_j)(e_i − e_j)ᵀ — the same for x and y — plus the orientation-form line
  // terms α(u_i − u_s)² of lines whose normal is that axis, restricted to the free unknowns.
  // The Laplacian is assembled once on the vertices free along some axis and ordered there by
  // AMD; each axis numbers its free unknowns in that order (CHOLMOD keeps it) and takes its
  // system from that one — only an axis with line terms is assembled again.
  void factor_axes(double alpha) {
    const int n = int(mesh.vertices.size());
    std::vector<Spring> springs;
    springs.reserve(mesh.triangles.size() * 3);
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
      for (int k = 0; k < 3; ++k) springs.push_back({mesh.triangles[f][k], mesh.triangles[f][(k + 1) % 3], weights[f]});
    std::vector<int> unknown(n, -1), vertex_of;
    for (int i = 0; i < n; ++i)
      if (!fixed_x[i] || !fixed_y[i]) unknown[i] = int(vertex_of.size()), vertex_of.push_back(i);
    std::vector<Coupling> laplacian_coupling;
    const SpMat laplacian = spring_matrix(springs, unknown, int(vertex_of.size()), &laplacian_coupling);
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> elimination;
    Eigen::AMDOrdering<int>()(laplacian.selfadjointView<Eigen::Lower>(), elimination);
    std::vector<int> order(vertex_of.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = vertex_of[elimination.indices()[k]];
    number_unknowns(order);

    // Factors one axis's system (line terms with normal `kind`); returns whether it has line terms.
    auto build = [&](LineKind kind, const std::vector<int>& free, int n_free, std::shared_ptr<const AxisFactor>& solver,
                     std::vector<Coupling>& coupling) {
      const std::size_t shape_springs = springs.size();
      for (const Line& l : lines)
        if (l.kind == kind)  // the fast path has only lines held at vertices
          for (std::size_t k = 1; k < l.points.size(); ++k)
            springs.push_back({l.points[k].vertices[0], l.points[0].vertices[0], alpha});
      const bool with_lines = springs.size() > shape_springs;
      // Every vertex of this axis fixed (a coarsest mesh with no interior vertex: images whose
      // short side is under ~110 px, see shape_warp.h): the axis is determined and there is
      // nothing to factor. CHOLMOD must not be given the empty matrix: Eigen hands it a null
      // value array, cholmod_analyze refuses it ("invalid xtype") and returns no factor, which
      // Eigen's factorize() then dereferences.
      if (n_free > 0 && with_lines) {
        solver = std::make_shared<AxisFactor>(spring_matrix(springs, free, n_free, &coupling));
      } else if (n_free > 0) {
        std::vector<int> keep(vertex_of.size());
        for (std::size_t u = 0; u < keep.size(); ++u) keep[u] = free[vertex_of[u]];
        solver = std::make_shared<AxisFactor>(restricted_form(laplacian, laplacian_coupling, keep, n_free, vertex_of, &coupling));
      }
      springs.resize(shape_springs);
      return with_lines;
    };
    // x: vertical lines keep their x (normal (1,0)); y: horizontal lines keep their y.
    const bool x_lines = build(LineKind::kVertical, free_x, n_free_x, solver_x, coupling_x);
    // When both axes fix the same vertices and carry no line terms — a local solve away from the
    // image border, the usual case for a pan — their systems are the same matrix: factor it once.
    const bool y_lines = std::any_of(lines.begin(), lines.end(), [](const Line& l) { return l.kind == LineKind::kHorizontal; });
    if (!x_lines && !y_lines && free_x == free_y) {
      solver_y = solver_x;
      coupling_y = coupling_x;
    } else {
      build(LineKind::kHorizontal, free_y, n_free_y, solver_y, coupling_y);
    }
  }

  // Per triangle, its edge vectors d_e = v_i − v_j (edge e = (k, k + 1)) in the source,
  // Σ_e |d_e|², and its corners' unknowns along x then y (−1: fixed): read by every local step
  // and right-hand side, so found once (after the unknowns are numbered).
  std::vector<std::array<Point, 3>> edge;
  std::vector<double> edge_norm2;
  std::vector<std::array<int, 6>> corner_unknowns;
  // The rotation term's row per triangle: r_f = A_f,10 − A_f,01 = Σ_k rx_k x'_k + ry_k y'_k over
  // its corners (WarpOptions::rotation_weight), and the triangle's source area A_f.
  struct RotationRow {
    std::array<double, 3> rx, ry;
    double area;
  };
  std::vector<RotationRow> rotation_row;

  void measure_edges() {
    edge.resize(mesh.triangles.size()), edge_norm2.resize(mesh.triangles.size());
    corner_unknowns.resize(mesh.triangles.size());
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
      for (int k = 0; k < 3; ++k)
        corner_unknowns[f][k] = free_x[mesh.triangles[f][k]], corner_unknowns[f][3 + k] = free_y[mesh.triangles[f][k]];
      double den = 0;
      for (int k = 0; k < 3; ++k) {
        const Point &a = mesh.vertices[mesh.triangles[f][k]], &b = mesh.vertices[mesh.triangles[f][(k + 1) % 3]];
        edge[f][k] = {a.x - b.x, a.y - b.y};
        den += edge[f][k].x * edge[f][k].x + edge[f][k].y * edge[f][k].y;
      }
      edge_norm2[f] = den;
    }
    // A = D S⁻¹ with S = [v1 − v0, v2 − v0] in the source and D the same on the target, so
    // r = (d1·s2 − d2·s1)/det S over the edges' x and y parts (d, s from v0): linear in v'.
    rotation_row.resize(mesh.triangles.size());
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
      const Triangle& t = mesh.triangles[f];
      const Point &v0 = mesh.vertices[t[0]], &v1 = mesh.vertices[t[1]], &v2 = mesh.vertices[t[2]];
      const Point s1{v1.x - v0.x, v1.y - v0.y}, s2{v2.x - v0.x, v2.y - v0.y};
      const double det = s1.x * s2.y - s2.x * s1.y;
      RotationRow& row = rotation_row[f];
      row.area = 0.5 * std::abs(det);
      if (det == 0) {  // a degenerate triangle has no affine map to turn
        row = {{0, 0, 0}, {0, 0, 0}, 0};
        continue;
      }
      row.rx = {(s1.x - s2.x) / det, s2.x / det, -s1.x / det};
      row.ry = {(s1.y - s2.y) / det, s2.y / det, -s1.y / det};
    }
  }

  // ρ Σ_f w_f A_f r_f² of positions p.
  double rotation_energy(const std::vector<Point>& p, const std::vector<double>& w, double rho) const {
    if (rho == 0) return 0;
    double e = 0;
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
      const Triangle& t = mesh.triangles[f];
      const RotationRow& row = rotation_row[f];
      double r = 0;
      for (int k = 0; k < 3; ++k) r += row.rx[k] * p[t[k]].x + row.ry[k] * p[t[k]].y;
      e += rho * w[f] * row.area * r * r;
    }
    return e;
  }

  // The optimal isotropic scale s_f of each triangle for positions p (the "local" step) and, if
  // asked, the shape energy D_Shape of p at those scales under weights w: one pass for both, as
  // an accelerated step needs the energy of the positions whose scales the next step starts from.
  std::vector<double> scales(const std::vector<Point>& p, const std::vector<double>& w, double* energy = nullptr) const {
    std::vector<double> s(mesh.triangles.size());
    double e = 0;
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
      const Triangle& t = mesh.triangles[f];
      std::array<Point, 3> warped;
      double num = 0;
      for (int k = 0; k < 3; ++k) {
        const Point &a = p[t[k]], &b = p[t[(k + 1) % 3]];
        warped[k] = {a.x - b.x, a.y - b.y};
        num += warped[k].x * edge[f][k].x + warped[k].y * edge[f][k].y;
      }
      s[f] = edge_norm2[f] > 0 ? num / edge_norm2[f] : 1.0;
      if (!energy) continue;
      for (int k = 0; k < 3; ++k) {
        const double ex = warped[k].x - s[f] * edge[f][k].x, ey = warped[k].y - s[f] * edge[f][k].y;
        e += w[f] * (ex * ex + ey * ey);
      }
    }
    if (energy) *energy = e;
    return s;
  }

  // Adds the shape term's right-hand sides of both axes, b_i = Σ w_f s_f (u_i − u_j) over
  // edges, to bx (indexed by free_x) and by (by free_y).
  void add_shape_rhs(const std::vector<double>& s, const std::vector<double>& w, double* bx, double* by) const {
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
      const double ws = w[f] * s[f];
      const std::array<int, 6>& u = corner_unknowns[f];
      for (int k = 0; k < 3; ++k) {
        const int i = k, j = (k + 1) % 3;
        const double cx = ws * edge[f][k].x, cy = ws * edge[f][k].y;
        if (u[i] >= 0) bx[u[i]] += cx;
        if (u[j] >= 0) bx[u[j]] -= cx;
        if (u[3 + i] >= 0) by[u[3 + i]] += cy;
        if (u[3 + j] >= 0) by[u[3 + j]] -= cy;
      }
    }
  }

  std::vector<int> inverted(const std::vector<Point>& p) const { return folded_triangles(mesh, p); }

  std::vector<Point> fixed_positions(const std::vector<Point>& start, double tw, double th) const {
    std::vector<Point> p = start;
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (fixed_x[i] == 1 || fixed_x[i] == 2) p[i].x = fixed_x[i] == 1 ? 0 : tw;
      if (fixed_y[i] == 1 || fixed_y[i] == 2) p[i].y = fixed_y[i] == 1 ? 0 : th;
    }
    return p;
  }

  // −A_FC x_C of both axes for fixed values taken from `p` (constant during a solve).
  std::pair<Eigen::VectorXd, Eigen::VectorXd> fixed_rhs(const std::vector<Point>& p) const {
    Eigen::VectorXd bx = Eigen::VectorXd::Zero(n_free_x), by = Eigen::VectorXd::Zero(n_free_y);
    for (const Coupling& c : coupling_x) bx[c.row] -= c.value * p[c.vertex].x;
    for (const Coupling& c : coupling_y) by[c.row] -= c.value * p[c.vertex].y;
    return {std::move(bx), std::move(by)};
  }

  // One global step of the fast path from positions with scales `s`; `fixed` is fixed_rhs() of
  // the solve.
  void solve_decoupled(std::vector<Point>& cur, const std::vector<double>& s,
                       const std::pair<Eigen::VectorXd, Eigen::VectorXd>& fixed) const {
    Eigen::VectorXd bx = Eigen::VectorXd::Zero(n_free_x), by = Eigen::VectorXd::Zero(n_free_y);
    add_shape_rhs(s, weights, bx.data(), by.data());
    bx += fixed.first, by += fixed.second;
    const Eigen::VectorXd x = solver_x ? Eigen::VectorXd(solver_x->solve(bx)) : bx;
    const Eigen::VectorXd y = solver_y ? Eigen::VectorXd(solver_y->solve(by)) : by;
    for (std::size_t i = 0; i < cur.size(); ++i) {
      if (free_x[i] >= 0) cur[i].x = x[free_x[i]];
      if (free_y[i] >= 0) cur[i].y = y[free_y[i]];
    }
  }

  // One global step with oblique lines: x and y are solved jointly. Unknowns: free x first, then
  // free y. Even iterations use the direction form D_Line_D (ratios r_i fixed), odd ones the
  // orientation form D_Line_O (normal fixed), as [ICAZ §4.2] prescribes.
  void solve_joint(std::vector<Point>& cur, double tw, double th, double alpha, double rho, int iteration,
                   const std::vector<double>& w) const {
    const int n = n_free_x + n_free_y;
    if (n == 0) return;  // every coordinate fixed: nothing to solve, and nothing CHOLMOD accepts
    auto [a, b] = joint_system(cur, tw, th, alpha, rho, iteration % 2 == 0, w, cur);
    b += joint_shape_rhs(scales(cur, w), w);
    Solver solver;
    solver.compute(a);
    if (solver.info() != Eigen::Success) throw std::runtime_error("CHOLMOD could not factor the warp system");
    write_joint(cur, solver.solve(b));
  }

  // The shape term's right-hand side for the joint unknowns (free x, then free y), from scales s.
  Eigen::VectorXd joint_shape_rhs(const std::vector<double>& s, const std::vector<double>& w) const {
    Eigen::VectorXd b = Eigen::VectorXd::Zero(n_free_x + n_free_y);
    add_shape_rhs(s, w, b.data(), b.data() + n_free_x);
    return b;
  }

  void write_joint(std::vector<Point>& cur, const Eigen::VectorXd& u) const {
    for (std::size_t i = 0; i < cur.size(); ++i) {
      if (free_x[i] >= 0) cur[i].x = u[free_x[i]];
      if (free_y[i] >= 0) cur[i].y = u[n_free_x + free_y[i]];
    }
  }

  // The joint system's matrix, and its right-hand side without the shape term (which alone
  // depends on s_f): shape Laplacian on both axes, line terms — oblique ones in the direction
  // form (`direction_form`, ratios from `cur`) or the orientation form (normal from `normals`) —
  // with fixed coordinates moved to the right.
  std::pair<SpMat, Eigen::VectorXd> joint_system(const std::vector<Point>& cur, double tw, double th, double alpha,
                                                 double rho, bool direction_form_step, const std::vector<double>& w,
                                                 const std::vector<Point>& normals) const {
    const int n = n_free_x + n_free_y;
    auto vx = [&](int i) { return free_x[i]; };
    auto vy = [&](int i) { return free_y[i] < 0 ? -1 : n_free_x + free_y[i]; };
    // Only the lower triangle: the solvers read the matrix as selfadjointView<Lower>. Reserved
    // for the most a term adds (2 axes × 3 edges × 3 per triangle; per line point, its corners'
    // coordinates and the start's, squared), which on retarget-zoom's 48k-triangle mesh spares
    // ~20 reallocations of the list per factorization.
    Triplets t;
    std::size_t line_terms = 0;
    for (const Line& l : lines)
      for (const CornerPoint& p : l.points) line_terms += std::size_t(2 * (corners(p) + corners(l.points.front()))) *
                                                          std::size_t(2 * (corners(p) + corners(l.points.front())));
    t.reserve((rho > 0 ? 39 : 18) * mesh.triangles.size() + line_terms);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(n);
    // Adds w·(Σ c_k u_k)² over `count` coordinates; a fixed one (unknown −1) has its value known.
    struct Term {
      int unknown;
      double c, known;
    };
    auto add = [&](const Term* terms, int count, double w) {
      double k0 = 0;
      for (int p = 0; p < count; ++p)
        if (terms[p].unknown < 0) k0 += terms[p].c * terms[p].known;
      for (int p = 0; p < count; ++p) {
        const int u = terms[p].unknown;
        if (u < 0) continue;
        b[u] -= w * terms[p].c * k0;
        for (int q = 0; q < count; ++q)
          if (terms[q].unknown >= 0 && terms[q].unknown <= u) t.emplace_back(u, terms[q].unknown, w * terms[p].c * terms[q].c);
      }
    };
    const auto fixed = fixed_positions(cur, tw, th);
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
      for (int k = 0; k < 3; ++k) {
        const int i = mesh.triangles[f][k], j = mesh.triangles[f][(k + 1) % 3];
        // The shape RHS is already in b; add the matrix, with fixed ends moved to the RHS.
        const Term x[2] = {{vx(i), 1, fixed[i].x}, {vx(j), -1, fixed[j].x}};
        const Term y[2] = {{vy(i), 1, fixed[i].y}, {vy(j), -1, fixed[j].y}};
        add(x, 2, w[f]);
        add(y, 2, w[f]);
      }
    if (rho > 0)
      for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
        const Triangle& tri = mesh.triangles[f];
        const RotationRow& row = rotation_row[f];
        Term r[6];
        for (int k = 0; k < 3; ++k) {
          r[k] = {vx(tri[k]), row.rx[k], fixed[tri[k]].x};
          r[3 + k] = {vy(tri[k]), row.ry[k], fixed[tri[k]].y};
        }
        add(r, 6, rho * w[f] * row.area);
      }
    // Line terms: each point's coordinates are its corners' (CornerPoint), so a term has up to 18.
    std::array<Term, 18> terms;
    int count = 0;
    auto put = [&](const CornerPoint& p, double c, bool along_x) {
      for (int j = 0; j < 3; ++j) {
        if (p.weights[j] == 0) continue;
        const int v = p.vertices[j];
        terms[count++] = {along_x ? vx(v) : vy(v), c * p.weights[j], along_x ? fixed[v].x : fixed[v].y};
      }
    };
    for (const Line& l : lines) {
      const CornerPoint &st = l.points.front(), &en = l.points.back();
      const auto [nx, ny] = line_normal(l, normals);
      const bool direction_form = l.kind == LineKind::kOblique && direction_form_step;
      const Point ps = position(st, cur), pe = position(en, cur);
      const double ex = pe.x - ps.x, ey = pe.y - ps.y, e2 = ex * ex + ey * ey;
      // The direction form says nothing about the end point itself (r = 1); the orientation form
      // keeps it on the line too.
      const std::size_t last = direction_form ? l.points.size() - 1 : l.points.size();
      for (std::size_t k = 1; k < last; ++k) {
        const CornerPoint& q = l.points[k];
        if (direction_form) {  // ‖v'_i − (1 − r) v'_s − r v'_e‖², per axis
          const Point pq = position(q, cur);
          const double r = e2 > 0 ? ((pq.x - ps.x) * ex + (pq.y - ps.y) * ey) / e2 : 0;
          for (bool along_x : {true, false}) {
            count = 0;
            put(q, 1, along_x), put(st, -(1 - r), along_x), put(en, -r, along_x);
            add(terms.data(), count, alpha);
          }
        } else {  // ((v'_i − v'_s)·n)²
          count = 0;
          put(q, nx, true), put(st, -nx, true), put(q, ny, false), put(st, -ny, false);
          add(terms.data(), count, alpha);
        }
      }
    }
    SpMat a(n, n);
    a.setFromTriplets(t.begin(), t.end());
    return {std::move(a), std::move(b)};
  }

  // Line energy α Σ ((v'_i − v'_s)·n)² with each line's normal taken from `normals`.
  double line_energy(const std::vector<Point>& p, const std::vector<Point>& normals, double alpha) const {
    double e = 0;
    for (const Line& l : lines) {
      const Point st = position(l.points.front(), p);
      const auto [nx, ny] = line_normal(l, normals);
      for (const CornerPoint& q : l.points) {
        const Point pq = position(q, p);
        const double d = (pq.x - st.x) * nx + (pq.y - st.y) * ny;
        e += alpha * d * d;
      }
    }
    return e;
  }
};

namespace {

// The joint path with every line's normal fixed (WarpOptions::fixed_line_normals): the matrix
// is constant through the solve, so it is factored once and each iteration is one
// back-substitution, like the fast path.
struct ConstantJoint {
  Solver solver;
  Eigen::VectorXd constant;  // right-hand side without the shape term
};

}  // namespace

ShapeWarp::ShapeWarp(Mesh mesh, std::vector<double> weights, double width, double height,
                     const std::vector<Segment>& lines, const std::vector<int>& pinned)
    : impl_(std::make_unique<Impl>()) {
  if (weights.size() != mesh.triangles.size()) throw std::invalid_argument("one weight per triangle");
  // The systems are SPD only with positive weights (and a fixed vertex per connected part, which
  // the rectangle's corners give): checked here rather than left to CHOLMOD.
  for (double w : weights)
    if (!(w > 0) || !std::isfinite(w)) throw std::invalid_argument("triangle weights must be positive and finite");
  if (!(width > 0) || !(height > 0) || !std::isfinite(width) || !std::isfinite(height))
    throw std::invalid_argument("empty source rectangle");
  impl_->mesh = std::move(mesh);
  impl_->weights = std::move(weights);
  impl_->width = width;
  impl_->height = height;
  for (const Segment& s : lines) {
    const double len = std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
    const LineKind kind = std::abs(s.b.y - s.a.y) <= 1e-9 * len   ? LineKind::kHorizontal
                          : std::abs(s.b.x - s.a.x) <= 1e-9 * len ? LineKind::kVertical
                                                                  : LineKind::kOblique;
    for (auto& points : held_parts(impl_->mesh, s)) {
      const bool on_vertices = std::all_of(points.begin(), points.end(), [](const CornerPoint& p) { return is_vertex(p); });
      impl_->has_oblique |= kind == LineKind::kOblique || !on_vertices;
      impl_->lines.push_back({std::move(points), kind});
    }
  }
  impl_->classify(pinned);
  if (!impl_->has_oblique) impl_->factor_axes(WarpOptions{}.alpha);
  impl_->measure_edges();
}

ShapeWarp::~ShapeWarp() = default;
ShapeWarp::ShapeWarp(ShapeWarp&&) noexcept = default;

const Mesh& ShapeWarp::mesh() const { return impl_->mesh; }
bool ShapeWarp::factored_once() const { return !impl_->has_oblique; }

WarpResult ShapeWarp::solve(double tw, double th, const WarpOptions& options, const std::vector<Point>& initial) const {
  const Impl& m = *impl_;
  WarpResult r;
  if (initial.size() == m.mesh.vertices.size()) {
    r.positions = m.fixed_positions(initial, tw, th);
  } else if (m.has_pinned) {
    throw std::invalid_argument("a warp with pinned vertices needs initial positions");
  } else {
    r.positions.resize(m.mesh.vertices.size());
    for (std::size_t i = 0; i < r.positions.size(); ++i)
      r.positions[i] = {m.mesh.vertices[i].x * tw / m.width, m.mesh.vertices[i].y * th / m.height};
  }
  // The fast path's factorization was made with the default α and no rotation term; anything
  // else needs the joint path.
  const bool fast = !m.has_oblique && options.alpha == WarpOptions{}.alpha && options.rotation_weight == 0;
  // Anderson acceleration (window 5) of the fixed-point map u ← G(u) of a constant system (the
  // fast path, or the joint one with fixed line normals): local–global converges linearly, and
  // extrapolating from the last few steps cuts the iterations several times. Safeguard [Peng et
  // al. 2018, "Anderson acceleration for geometry optimization"]: an accelerated step whose
  // energy is not below the previous iterate's is dropped (and the history cleared) in favour of
  // the plain step — local–global never raises it, so the energy still falls monotonically, and
  // only the accelerated positions' energy is evaluated (comparing against the plain step's too
  // cost a second pass over the triangles per iteration and, on 440 views of 4 images, never
  // chose differently).
  constexpr int kWindow = 5;
  const int n2 = int(2 * r.positions.size());
  auto stack = [&](const std::vector<Point>& p) {
    Eigen::VectorXd v(n2);
    for (std::size_t i = 0; i < p.size(); ++i) v[2 * i] = p[i].x, v[2 * i + 1] = p[i].y;
    return v;
  };
  auto unstack = [&](const Eigen::VectorXd& v) {
    std::vector<Point> p(v.size() / 2);
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = {v[2 * i], v[2 * i + 1]};
    return p;
  };
  const std::vector<Point> start = r.positions;
  const auto fixed = fast && options.max_iterations > 0 ? m.fixed_rhs(start) : std::pair<Eigen::VectorXd, Eigen::VectorXd>{};
  // Iterates r.positions on weights `w` — the fast path when `joint` is null, else `joint`'s
  // system, whose lines' normals come from `normals` — until no vertex moves more than the
  // tolerance or `max_iterations` are spent; says whether it converged.
  auto accelerated = [&](const std::vector<double>& w, const ConstantJoint* joint, const std::vector<Point>& normals,
                         int max_iterations) {
    // The last kWindow differences of steps (G) and of residuals (F), one per column in the order
    // they fill the ring (least squares does not care which column is which); `history` of them.
    Eigen::MatrixXd dg(n2, kWindow), df(n2, kWindow);
    int history = 0, next_column = 0;
    Eigen::VectorXd g_prev, f_prev;
    // What an accelerated step must lower: the shape energy (the fast path's H/V line terms are
    // nearly met by construction), plus the line and rotation energies of the joint system.
    // The scales of p come with it: the next step starts from whichever positions are kept.
    auto objective = [&](const std::vector<Point>& p, std::vector<double>& scales_of_p) {
      double shape = 0;
      scales_of_p = m.scales(p, w, &shape);
      if (!joint) return shape;
      return shape + m.line_energy(p, normals, options.alpha) + m.rotation_energy(p, w, options.rotation_weight);
    };
    std::vector<double> scales;  // of r.positions, when `scales_current`
    double energy = 0;           // objective of r.positions, likewise
    bool scales_current = false;
    for (int k = 0; k < max_iterations; ++k) {
      check_stop(options.stop);
      const std::vector<Point> before = r.positions;
      // The energy is compared from the second step on, once there is a step to extrapolate from.
      if (!scales_current && k == 0) scales = m.scales(r.positions, w);
      else if (!scales_current) energy = objective(r.positions, scales);
      std::vector<Point> step = r.positions;
      if (joint) m.write_joint(step, joint->solver.solve(joint->constant + m.joint_shape_rhs(scales, w)));
      else m.solve_decoupled(step, scales, fixed);
      const Eigen::VectorXd u = stack(r.positions), g = stack(step), f = g - u;
      if (g_prev.size() == n2) {
        dg.col(next_column) = g - g_prev, df.col(next_column) = f - f_prev;
        next_column = (next_column + 1) % kWindow, history = std::min(history + 1, kWindow);
      }
      g_prev = g, f_prev = f;
      r.positions = step;
      scales_current = false;
      if (history > 0) {
        const auto F = df.leftCols(history), G = dg.leftCols(history);
        // The least-squares coefficients from the k × k normal equations (k ≤ 5) rather than a
        // QR of the n × k history: the same steps on 440 views of 4 images (1e-11 px) at a
        // tenth of a solve less; an ill-conditioned history gives at worst a step the safeguard
        // rejects (LDLT leaves a zero pivot's coefficient at 0).
        const Eigen::VectorXd gamma = (F.transpose() * F).ldlt().solve(F.transpose() * f);
        std::vector<Point> extrapolated = unstack(g - G * gamma);
        std::vector<double> extrapolated_scales;
        const double extrapolated_energy = objective(extrapolated, extrapolated_scales);
        if (extrapolated_energy < energy) {
          r.positions = std::move(extrapolated), scales = std::move(extrapolated_scales);
          energy = extrapolated_energy, scales_current = true;
        } else {
          history = next_column = 0;
        }
      }
      ++r.iterations;
      if (largest_move(before, r.positions) < options.tolerance) return true;
    }
    return false;
  };
  // The joint system with line normals fixed from `from` and weights `w`, factored once. Every
  // such system of a solve has one sparsity pattern (weights and normals change only values),
  // so after the first only the numeric factorization is redone, in `joint`'s own solver: the
  // fill-reducing ordering and symbolic analysis were ~10 % of a guard round.
  auto constant_joint = [&](const std::vector<Point>& from, const std::vector<double>& w,
                            std::unique_ptr<ConstantJoint> joint) {
    auto [a, b] = m.joint_system(from, tw, th, options.alpha, options.rotation_weight, false, w, from);
    if (joint) {
      joint->solver.factorize(a);
    } else {
      joint = std::make_unique<ConstantJoint>();
      joint->solver.compute(a);
    }
    if (joint->solver.info() != Eigen::Success) throw std::runtime_error("CHOLMOD could not factor the warp system");
    joint->constant = std::move(b);
    return joint;
  };
  const bool has_unknowns = m.n_free_x + m.n_free_y > 0;
  // Oblique lines with their normals fixed from the start: one factorization for the solve.
  std::unique_ptr<ConstantJoint> joint;
  if (!fast && options.fixed_line_normals && has_unknowns) joint = constant_joint(start, m.weights, nullptr);
  if (fast || joint) {
    r.converged = accelerated(m.weights, joint.get(), start, options.max_iterations);
  } else {
    for (r.iterations = 0; r.iterations < options.max_iterations;) {
      check_stop(options.stop);
      const std::vector<Point> before = r.positions;
      m.solve_joint(r.positions, tw, th, options.alpha, options.rotation_weight, r.iterations, m.weights);
      ++r.iterations;
      // Oblique lines alternate two forms: judge convergence after a pair of iterations.
      if (largest_move(before, r.positions) < options.tolerance && r.iterations % 2 == 0) {
        r.converged = true;
        break;
      }
    }
  }
  // Fold-over guard. The shape energy alone can invert triangles where weights are low next to
  // high ones (15 of 3348 with w_min = 0.05, docs/algorithms.md). Where that happens, the weights of
  // the inverted triangles and their neighbours are raised — making them resist deformation —
  // and the warp goes on from where it is, until no triangle is inverted.
  auto bad = m.inverted(r.positions);
  std::vector<double> w = m.weights;
  for (int round = 0; options.fold_guard && !bad.empty() && round < options.max_guard_rounds; ++round) {
    // The neighbourhood grows by one ring of triangles per round; the last round makes every
    // weight 1 (uniform weights warp the rectangle almost affinely, with nothing to fold).
    std::vector<char> near(m.mesh.vertices.size(), 0);
    for (int f : bad)
      for (int v : m.mesh.triangles[f]) near[v] = 1;
    for (int ring = 0; ring < round; ++ring) {
      std::vector<char> grown = near;
      for (const auto& t : m.mesh.triangles)
        if (near[t[0]] || near[t[1]] || near[t[2]]) grown[t[0]] = grown[t[1]] = grown[t[2]] = 1;
      near.swap(grown);
    }
    const bool last = round + 1 == options.max_guard_rounds;
    for (std::size_t f = 0; f < w.size(); ++f) {
      const auto& t = m.mesh.triangles[f];
      if (last) w[f] = 1;
      else if (near[t[0]] || near[t[1]] || near[t[2]]) w[f] = std::min(1.0, w[f] * 4);
    }
    // With fixed line normals a round's weights make its system constant: factored once a round
    // (normals from where the round starts) and iterated like the main solve.
    if (options.fixed_line_normals && has_unknowns) {
      const std::vector<Point> from = r.positions;
      joint = constant_joint(from, w, std::move(joint));
      accelerated(w, joint.get(), from, options.max_guard_iterations);
    } else {
      for (int k = 0; k < options.max_guard_iterations; ++k) {
        check_stop(options.stop);
        const std::vector<Point> before = r.positions;
        m.solve_joint(r.positions, tw, th, options.alpha, options.rotation_weight, r.iterations++, w);
        if (largest_move(before, r.positions) < options.tolerance && k % 2 == 1) break;
      }
    }
    bad = m.inverted(r.positions);
    r.guard_rounds = round + 1;
  }
  // Last resort, for extreme aspect changes (a 4:1 panorama on a 9:16 screen folded even with
  // uniform weights): blend towards the affine stretch, which folds nothing and meets the same
  // boundary constraints, as little as needed (bisection on the blend factor). With pinned
  // vertices the affine stretch would move them; the (fold-free) start is the fallback then.
  if (options.fold_guard && !bad.empty()) {
    std::vector<Point> affine = start;
    if (!m.has_pinned)
      for (std::size_t i = 0; i < affine.size(); ++i)
        affine[i] = {m.mesh.vertices[i].x * tw / m.width, m.mesh.vertices[i].y * th / m.height};
    r.affine_blend = blend_out_folds(m.mesh, r.positions, affine, options.stop);
    bad = m.inverted(r.positions);
  }
  r.inverted = int(bad.size());
  return r;
}

}  // namespace zoomwarp::warp
