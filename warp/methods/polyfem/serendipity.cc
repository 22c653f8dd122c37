#include "warp/methods/polyfem/serendipity.h"

#include <cmath>
#include <cstddef>
#include <stdexcept>

namespace zoomwarp::warp {

namespace {

// A forward-mode dual number: a value and its partial derivatives with respect to p = (x, y).
struct Dual {
  double v = 0, dx = 0, dy = 0;
};
Dual operator+(Dual a, Dual b) { return {a.v + b.v, a.dx + b.dx, a.dy + b.dy}; }
Dual operator-(Dual a, Dual b) { return {a.v - b.v, a.dx - b.dx, a.dy - b.dy}; }
Dual operator-(double a, Dual b) { return {a - b.v, -b.dx, -b.dy}; }
Dual operator*(Dual a, Dual b) { return {a.v * b.v, a.dx * b.v + a.v * b.dx, a.dy * b.v + a.v * b.dy}; }
Dual operator*(double a, Dual b) { return {a * b.v, a * b.dx, a * b.dy}; }
Dual operator/(Dual a, Dual b) {
  const double q = a.v / b.v;
  return {q, (a.dx - q * b.dx) / b.v, (a.dy - q * b.dy) / b.v};
}
Dual sqrt(Dual a) {
  const double r = std::sqrt(a.v);
  return {r, a.dx / (2 * r), a.dy / (2 * r)};
}

// A point's coordinates as the variables: dual numbers when gradients are wanted, plain doubles
// when only values are. The value parts of the dual arithmetic are the same operations in the
// same order as the plain ones, so both give the same values bit for bit.
template <class T>
T variable(double value, int axis);
template <>
double variable<double>(double value, int) { return value; }
template <>
Dual variable<Dual>(double value, int axis) { return {value, axis == 0 ? 1.0 : 0.0, axis == 1 ? 1.0 : 0.0}; }

// Per-thread working arrays: one evaluation per quadrature point or sample, hundreds of
// thousands per image, and allocating them each time cost as much as the arithmetic.
template <class T>
struct Scratch {
  std::vector<T> dx, dy, r, tan_half, lambda, xi_vertex, xi_edge;
};
template <class T>
Scratch<T>& scratch() {
  static thread_local Scratch<T> s;
  return s;
}

// λ (the formulas in the header), into s.lambda.
template <class T>
void mvc(const std::vector<Point>& polygon, const Point& p, Scratch<T>& s) {
  using std::sqrt;
  const std::size_t n = polygon.size();
  const T px = variable<T>(p.x, 0), py = variable<T>(p.y, 1);
  s.dx.resize(n), s.dy.resize(n), s.r.resize(n), s.tan_half.resize(n), s.lambda.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    s.dx[i] = polygon[i].x - px;
    s.dy[i] = polygon[i].y - py;
    s.r[i] = sqrt(s.dx[i] * s.dx[i] + s.dy[i] * s.dy[i]);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t k = i + 1 == n ? 0 : i + 1;
    s.tan_half[i] = (s.r[i] * s.r[k] - (s.dx[i] * s.dx[k] + s.dy[i] * s.dy[k])) / (s.dx[i] * s.dy[k] - s.dy[i] * s.dx[k]);
  }
  T sum{};
  for (std::size_t i = 0; i < n; ++i) {
    s.lambda[i] = (s.tan_half[i == 0 ? n - 1 : i - 1] + s.tan_half[i]) / s.r[i];
    sum = sum + s.lambda[i];
  }
  for (T& l : s.lambda) l = l / sum;
}

// ξ_ii at vertex i into s.xi_vertex, ξ_{i,i+1} at edge i into s.xi_edge (the header's basis),
// from s.lambda.
template <class T>
void serendipity_xi(const std::vector<SerendipityDiagonal>& diagonals, Scratch<T>& s) {
  const std::vector<T>& l = s.lambda;
  const std::size_t n = l.size();
  auto prev = [n](std::size_t k) { return k == 0 ? n - 1 : k - 1; };
  s.xi_vertex.resize(n), s.xi_edge.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    s.xi_vertex[i] = l[i] * l[i];
    s.xi_edge[i] = l[i] * l[i + 1 == n ? 0 : i + 1];
  }
  for (const SerendipityDiagonal& d : diagonals) {
    const std::size_t i = std::size_t(d.i), j = std::size_t(d.j);
    const T mu = l[i] * l[j];
    s.xi_vertex[i] = s.xi_vertex[i] + d.c_ii * mu;
    s.xi_vertex[j] = s.xi_vertex[j] + d.c_jj * mu;
    s.xi_edge[i] = s.xi_edge[i] + d.c_i_next * mu;
    s.xi_edge[prev(i)] = s.xi_edge[prev(i)] + d.c_i_prev * mu;
    s.xi_edge[j] = s.xi_edge[j] + d.c_j_next * mu;
    s.xi_edge[prev(j)] = s.xi_edge[prev(j)] + d.c_j_prev * mu;
  }
}

void require_polygon(const std::vector<Point>& polygon) {
  const std::size_t n = polygon.size();
  if (n < 3) throw std::invalid_argument("serendipity element: a polygon needs at least 3 vertices");
  int sign = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double turn = signed_area2(polygon[i], polygon[(i + 1) % n], polygon[(i + 2) % n]);
    const int s = turn > 0 ? 1 : turn < 0 ? -1 : 0;
    if (s == 0 || (sign != 0 && s != sign))
      throw std::invalid_argument("serendipity element: the polygon is not strictly convex");
    sign = s;
  }
}

double cross(const Point& a, const Point& b) { return a.x * b.y - a.y * b.x; }
Point operator-(const Point& a, const Point& b) { return {a.x - b.x, a.y - b.y}; }
double length(const Point& a) { return std::hypot(a.x, a.y); }

// Signed position t along û of line(o, o + û) ∩ line(a, b): (o + t·û − a) × (b − a) = 0.
double along(const Point& o, const Point& u, const Point& a, const Point& b) {
  return cross(a - o, b - a) / cross(u, b - a);
}

}  // namespace

void mean_value_coordinates(const std::vector<Point>& polygon, const Point& p, std::vector<double>& lambda,
                            std::vector<Point>& gradient) {
  Scratch<Dual>& s = scratch<Dual>();
  mvc(polygon, p, s);
  const std::vector<Dual>& l = s.lambda;
  lambda.resize(l.size());
  gradient.resize(l.size());
  for (std::size_t i = 0; i < l.size(); ++i) {
    lambda[i] = l[i].v;
    gradient[i] = {l[i].dx, l[i].dy};
  }
}

std::vector<SerendipityDiagonal> serendipity_coefficients(const std::vector<Point>& polygon) {
  require_polygon(polygon);
  const int n = int(polygon.size());
  auto v = [&](int k) { return polygon[(k + n) % n]; };
  std::vector<SerendipityDiagonal> diagonals;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 2; j < n - (i == 0 ? 1 : 0); ++j) {
      const Point e = v(j) - v(i);
      const double L = length(e);
      const Point u{e.x / L, e.y / L};
      // Signed positions along û, from v_i, of I_i, I_j and the midpoint v_ij.
      const double ti = along(v(i), u, v(i - 1), v(i + 1)), tj = along(v(i), u, v(j - 1), v(j + 1)), tm = L / 2;
      const double s = L / (L - (tj - ti));
      const Point Ii{v(i).x + ti * u.x, v(i).y + ti * u.y}, Ij{v(i).x + tj * u.x, v(i).y + tj * u.y};
      const double span_i = length(v(i - 1) - v(i + 1)), span_j = length(v(j - 1) - v(j + 1));
      diagonals.push_back({i, j, -s * (1 + 2 * (tm - ti) / L), -s * (1 + 2 * (tj - tm) / L),
                           s * length(Ii - v(i + 1)) / span_i, s * length(Ii - v(i - 1)) / span_i,
                           s * length(Ij - v(j + 1)) / span_j, s * length(Ij - v(j - 1)) / span_j});
    }
  }
  return diagonals;
}

void serendipity_basis(const std::vector<Point>& polygon, const std::vector<SerendipityDiagonal>& diagonals,
                       const Point& p, std::vector<double>& psi, std::vector<Point>& gradient) {
  Scratch<Dual>& s = scratch<Dual>();
  mvc(polygon, p, s);
  serendipity_xi(diagonals, s);
  const std::size_t n = polygon.size();
  psi.resize(2 * n);
  gradient.resize(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Dual vertex = s.xi_vertex[i] - s.xi_edge[i] - s.xi_edge[i == 0 ? n - 1 : i - 1];
    const Dual edge = 4 * s.xi_edge[i];
    psi[i] = vertex.v;
    gradient[i] = {vertex.dx, vertex.dy};
    psi[n + i] = edge.v;
    gradient[n + i] = {edge.dx, edge.dy};
  }
}

void serendipity_values(const std::vector<Point>& polygon, const std::vector<SerendipityDiagonal>& diagonals,
                        const Point& p, std::vector<double>& psi) {
  Scratch<double>& s = scratch<double>();
  mvc(polygon, p, s);
  serendipity_xi(diagonals, s);
  const std::size_t n = polygon.size();
  psi.resize(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    psi[i] = s.xi_vertex[i] - s.xi_edge[i] - s.xi_edge[i == 0 ? n - 1 : i - 1];
    psi[n + i] = 4 * s.xi_edge[i];
  }
}

}  // namespace zoomwarp::warp
