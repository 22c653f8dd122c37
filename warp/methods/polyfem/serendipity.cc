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

// λ as dual numbers (the formulas in the header).
std::vector<Dual> mvc(const std::vector<Point>& polygon, const Point& p) {
  const std::size_t n = polygon.size();
  const Dual px{p.x, 1, 0}, py{p.y, 0, 1};
  std::vector<Dual> dx(n), dy(n), r(n), tan_half(n);
  for (std::size_t i = 0; i < n; ++i) {
    dx[i] = polygon[i].x - px;
    dy[i] = polygon[i].y - py;
    r[i] = sqrt(dx[i] * dx[i] + dy[i] * dy[i]);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t k = (i + 1) % n;
    tan_half[i] = (r[i] * r[k] - (dx[i] * dx[k] + dy[i] * dy[k])) / (dx[i] * dy[k] - dy[i] * dx[k]);
  }
  std::vector<Dual> w(n);
  Dual sum;
  for (std::size_t i = 0; i < n; ++i) {
    w[i] = (tan_half[(i + n - 1) % n] + tan_half[i]) / r[i];
    sum = sum + w[i];
  }
  for (Dual& wi : w) wi = wi / sum;
  return w;
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
  const std::vector<Dual> l = mvc(polygon, p);
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
  const std::vector<Dual> l = mvc(polygon, p);
  const std::size_t n = l.size();
  auto prev = [n](std::size_t k) { return (k + n - 1) % n; };
  // ξ_ii at vertex i, ξ_{i,i+1} at edge i.
  std::vector<Dual> xi_vertex(n), xi_edge(n);
  for (std::size_t i = 0; i < n; ++i) {
    xi_vertex[i] = l[i] * l[i];
    xi_edge[i] = l[i] * l[(i + 1) % n];
  }
  for (const SerendipityDiagonal& d : diagonals) {
    const std::size_t i = std::size_t(d.i), j = std::size_t(d.j);
    const Dual mu = l[i] * l[j];
    xi_vertex[i] = xi_vertex[i] + d.c_ii * mu;
    xi_vertex[j] = xi_vertex[j] + d.c_jj * mu;
    xi_edge[i] = xi_edge[i] + d.c_i_next * mu;
    xi_edge[prev(i)] = xi_edge[prev(i)] + d.c_i_prev * mu;
    xi_edge[j] = xi_edge[j] + d.c_j_next * mu;
    xi_edge[prev(j)] = xi_edge[prev(j)] + d.c_j_prev * mu;
  }
  psi.resize(2 * n);
  gradient.resize(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Dual vertex = xi_vertex[i] - xi_edge[i] - xi_edge[prev(i)];
    const Dual edge = 4 * xi_edge[i];
    psi[i] = vertex.v;
    gradient[i] = {vertex.dx, vertex.dy};
    psi[n + i] = edge.v;
    gradient[n + i] = {edge.dx, edge.dy};
  }
}

}  // namespace zoomwarp::warp
