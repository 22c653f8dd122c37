// method=polyfem's element (warp/methods/polyfem/serendipity.h): mean value coordinates [Floater03]
// and the quadratic serendipity basis [PolyFEM §3.1 eq. 1, after Rand–Gillette–Bajaj] on random
// strictly convex polygons (n = 3 … 10, fixed seed) and a kite — partition of unity, reproduction
// of every quadratic, nodal interpolation and the 1-D P2 basis on the edges (as limits from
// inside), P2 Lagrange on triangles, gradients against finite differences; and the regression:
// [PolyFEM eq. 1]'s printed unsigned lengths do not reproduce constants on the kite.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "warp/methods/polyfem/serendipity.h"

namespace zoomwarp {
namespace {

using warp::Point;
using Polygon = std::vector<Point>;

Point lerp(const Point& a, const Point& b, double t) { return {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)}; }
double distance(const Point& a, const Point& b) { return std::hypot(a.x - b.x, a.y - b.y); }

Point centroid(const Polygon& poly) {
  Point c;
  for (const Point& v : poly) c = {c.x + v.x / poly.size(), c.y + v.y / poly.size()};
  return c;
}

double diameter(const Polygon& poly) {
  double d = 0;
  for (const Point& a : poly)
    for (const Point& b : poly) d = std::max(d, distance(a, b));
  return d;
}

// The 2n nodes in the basis's order: vertices, then edge midpoints.
std::vector<Point> nodes(const Polygon& poly) {
  std::vector<Point> k = poly;
  for (std::size_t i = 0; i < poly.size(); ++i) k.push_back(lerp(poly[i], poly[(i + 1) % poly.size()], 0.5));
  return k;
}

// A kite whose long diagonal (v_0, v_2) the short one crosses off-centre, at 1/3: from v_2's side
// I_2 lies past the diagonal's midpoint.
Polygon kite() { return {{0, 0}, {1, -1}, {3, 0}, {1, 1}}; }

// Random strictly convex n-gons: sorted angles on a perturbed circle, stretched and shifted;
// kept when every turn is at least 10° and no edge is shorter than a tenth of the longest.
Polygon random_convex(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(0, 1);
  for (;;) {
    std::vector<double> angle(n);
    for (double& a : angle) a = 2 * std::numbers::pi * u(rng);
    std::sort(angle.begin(), angle.end());
    const double sx = 0.5 + 1.5 * u(rng), ox = 10 * u(rng) - 5, oy = 10 * u(rng) - 5;
    Polygon poly;
    for (double a : angle) {
      const double r = 1 + 0.3 * u(rng);
      poly.push_back({ox + sx * r * std::cos(a), oy + r * std::sin(a)});
    }
    double shortest = 1e300, longest = 0;
    bool ok = true;
    for (int i = 0; i < n; ++i) {
      const Point& a = poly[i];
      const Point& b = poly[(i + 1) % n];
      const Point& c = poly[(i + 2) % n];
      const double e1 = distance(a, b), e2 = distance(b, c);
      shortest = std::min(shortest, e1);
      longest = std::max(longest, e1);
      ok = ok && warp::signed_area2(a, b, c) > std::sin(10 * std::numbers::pi / 180) * e1 * e2;
    }
    if (ok && shortest > 0.1 * longest) return poly;
  }
}

// The kite, then five random polygons for each n = 3 … 10.
const std::vector<Polygon>& polygons() {
  static const std::vector<Polygon> all = [] {
    std::mt19937 rng(15);
    std::vector<Polygon> p{kite()};
    for (int n = 3; n <= 10; ++n)
      for (int k = 0; k < 5; ++k) p.push_back(random_convex(rng, n));
    return p;
  }();
  return all;
}

// Points strictly inside: in a random fan triangle (centroid, v_i, v_{i+1}), pulled towards the
// centroid by `shrink` (1: anywhere in the polygon).
std::vector<Point> inside_points(const Polygon& poly, int count, double shrink = 1) {
  std::mt19937 rng(int(poly.size()) * 1000 + count);
  std::uniform_real_distribution<double> u(0, 1);
  const Point c = centroid(poly);
  std::vector<Point> pts;
  for (int k = 0; k < count; ++k) {
    const std::size_t i = std::size_t(u(rng) * poly.size()) % poly.size();
    double a = u(rng), b = u(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const Point q{c.x + a * (poly[i].x - c.x) + b * (poly[(i + 1) % poly.size()].x - c.x),
                  c.y + a * (poly[i].y - c.y) + b * (poly[(i + 1) % poly.size()].y - c.y)};
    pts.push_back(lerp(c, q, shrink));
  }
  return pts;
}

struct Basis {
  std::vector<double> psi;
  std::vector<Point> gradient;
};
Basis basis(const Polygon& poly, const Point& p) {
  Basis b;
  warp::serendipity_basis(poly, warp::serendipity_coefficients(poly), p, b.psi, b.gradient);
  return b;
}

std::string describe(const Polygon& poly, const Point& p) {
  std::string s = "n = " + std::to_string(poly.size()) + ", p = (" + std::to_string(p.x) + ", " + std::to_string(p.y) + "), polygon";
  for (const Point& v : poly) s += " (" + std::to_string(v.x) + ", " + std::to_string(v.y) + ")";
  return s;
}

TEST(PolyfemElement, MeanValueCoordinatesPartitionUnityAndLinearPrecision) {
  for (const Polygon& poly : polygons()) {
    for (const Point& p : inside_points(poly, 20)) {
      SCOPED_TRACE(describe(poly, p));
      std::vector<double> lambda;
      std::vector<Point> gradient;
      warp::mean_value_coordinates(poly, p, lambda, gradient);
      ASSERT_EQ(lambda.size(), poly.size());
      double sum = 0, x = 0, y = 0, gx = 0, gy = 0, gxx = 0, gyx = 0, gxy = 0, gyy = 0;
      for (std::size_t i = 0; i < poly.size(); ++i) {
        EXPECT_GE(lambda[i], 0);  // positive inside a convex polygon [Floater03]
        sum += lambda[i];
        x += lambda[i] * poly[i].x, y += lambda[i] * poly[i].y;
        gx += gradient[i].x, gy += gradient[i].y;
        gxx += gradient[i].x * poly[i].x, gyx += gradient[i].y * poly[i].x;
        gxy += gradient[i].x * poly[i].y, gyy += gradient[i].y * poly[i].y;
      }
      const double scale = diameter(poly) + std::hypot(p.x, p.y);
      EXPECT_NEAR(sum, 1, 1e-12);
      EXPECT_NEAR(x, p.x, 1e-12 * scale);
      EXPECT_NEAR(y, p.y, 1e-12 * scale);
      // Differentiated: Σ∇λ_i = 0 and Σ v_i ⊗ ∇λ_i = I.
      EXPECT_NEAR(gx, 0, 1e-9 * scale);
      EXPECT_NEAR(gy, 0, 1e-9 * scale);
      EXPECT_NEAR(gxx, 1, 1e-9 * scale);
      EXPECT_NEAR(gyy, 1, 1e-9 * scale);
      EXPECT_NEAR(gyx, 0, 1e-9 * scale);
      EXPECT_NEAR(gxy, 0, 1e-9 * scale);
    }
  }
}

TEST(PolyfemElement, PartitionOfUnity) {
  for (const Polygon& poly : polygons()) {
    for (const Point& p : inside_points(poly, 20)) {
      SCOPED_TRACE(describe(poly, p));
      const Basis b = basis(poly, p);
      ASSERT_EQ(b.psi.size(), 2 * poly.size());
      double sum = 0;
      for (double v : b.psi) sum += v;
      EXPECT_NEAR(sum, 1, 1e-12);
    }
  }
}

// The values alone (what sampling uses) are serendipity_basis's to the bit: the samplings, and
// with them the stored chord deviations, do not depend on which of the two made them.
TEST(PolyfemElement, ValuesAloneAreTheBasisValuesBitForBit) {
  for (const Polygon& poly : polygons()) {
    const auto diagonals = warp::serendipity_coefficients(poly);
    for (const Point& p : inside_points(poly, 20)) {
      SCOPED_TRACE(describe(poly, p));
      const Basis b = basis(poly, p);
      std::vector<double> psi;
      warp::serendipity_values(poly, diagonals, p, psi);
      ASSERT_EQ(psi.size(), b.psi.size());
      for (std::size_t k = 0; k < psi.size(); ++k) EXPECT_EQ(psi[k], b.psi[k]) << k;
    }
  }
}

// Per diagonal c^{ii} + c^{jj} + 2·(c^{i,i−1} + c^{i,i+1} + c^{j,j−1} + c^{j,j+1}) = 2 — what Σψ = 1
// needs (serendipity.h) — over all n(n − 3)/2 diagonals, all edge coefficients positive.
TEST(PolyfemElement, DiagonalCoefficientsSumToTwo) {
  for (const Polygon& poly : polygons()) {
    SCOPED_TRACE(describe(poly, centroid(poly)));
    const std::size_t n = poly.size();
    const auto diagonals = warp::serendipity_coefficients(poly);
    EXPECT_EQ(diagonals.size(), n * (n - 3) / 2);
    for (const warp::SerendipityDiagonal& d : diagonals) {
      EXPECT_NEAR(d.c_ii + d.c_jj + 2 * (d.c_i_prev + d.c_i_next + d.c_j_prev + d.c_j_next), 2, 1e-12)
          << "diagonal (" << d.i << ", " << d.j << ")";
      EXPECT_GT(std::min({d.c_i_prev, d.c_i_next, d.c_j_prev, d.c_j_next}), 0);
    }
  }
}

// Σ_k ψ_k·f(node_k) = f(p) and Σ_k ∇ψ_k·f(node_k) = ∇f(p) for f = 1, x, y, x², xy, y².
TEST(PolyfemElement, ReproducesQuadratics) {
  struct Quadratic {
    const char* name;
    std::function<double(const Point&)> f;
    std::function<Point(const Point&)> grad;
  };
  const Quadratic quadratics[] = {
      {"1", [](const Point&) { return 1.0; }, [](const Point&) { return Point{0, 0}; }},
      {"x", [](const Point& q) { return q.x; }, [](const Point&) { return Point{1, 0}; }},
      {"y", [](const Point& q) { return q.y; }, [](const Point&) { return Point{0, 1}; }},
      {"x²", [](const Point& q) { return q.x * q.x; }, [](const Point& q) { return Point{2 * q.x, 0}; }},
      {"xy", [](const Point& q) { return q.x * q.y; }, [](const Point& q) { return Point{q.y, q.x}; }},
      {"y²", [](const Point& q) { return q.y * q.y; }, [](const Point& q) { return Point{0, 2 * q.y}; }},
  };
  for (const Polygon& poly : polygons()) {
    const std::vector<Point> node = nodes(poly);
    for (const Point& p : inside_points(poly, 20)) {
      const Basis b = basis(poly, p);
      for (const Quadratic& q : quadratics) {
        SCOPED_TRACE(std::string("f = ") + q.name + ", " + describe(poly, p));
        double value = 0, gx = 0, gy = 0, scale = 0;
        for (std::size_t k = 0; k < node.size(); ++k) {
          const double fk = q.f(node[k]);
          value += b.psi[k] * fk;
          gx += b.gradient[k].x * fk, gy += b.gradient[k].y * fk;
          scale = std::max(scale, std::abs(fk));
        }
        EXPECT_NEAR(value, q.f(p), 1e-10 * scale);
        EXPECT_NEAR(gx, q.grad(p).x, 1e-9 * scale);
        EXPECT_NEAR(gy, q.grad(p).y, 1e-9 * scale);
      }
    }
  }
}

// ψ_k → δ_km approaching node m from inside (the basis is never evaluated on the boundary).
TEST(PolyfemElement, NodalInterpolation) {
  for (const Polygon& poly : polygons()) {
    const std::vector<Point> node = nodes(poly);
    const Point c = centroid(poly);
    for (std::size_t m = 0; m < node.size(); ++m) {
      const Point p = lerp(node[m], c, 1e-8);
      SCOPED_TRACE("node " + std::to_string(m) + ", " + describe(poly, p));
      const Basis b = basis(poly, p);
      for (std::size_t k = 0; k < node.size(); ++k) EXPECT_NEAR(b.psi[k], k == m ? 1 : 0, 1e-6) << "k = " << k;
    }
  }
}

// Approaching edge (v_i, v_{i+1}) at parameter t, the basis is the 1-D P2 basis of its nodes
// v_i, v_{i+1} and their midpoint; every other ψ vanishes.
TEST(PolyfemElement, EdgeRestrictionIsOneDimensionalP2) {
  for (const Polygon& poly : polygons()) {
    const std::size_t n = poly.size();
    const Point c = centroid(poly);
    for (std::size_t i = 0; i < n; ++i) {
      for (double t : {0.1, 0.3, 0.5, 0.77, 0.9}) {
        const Point p = lerp(lerp(poly[i], poly[(i + 1) % n], t), c, 1e-9);
        SCOPED_TRACE("edge " + std::to_string(i) + ", t = " + std::to_string(t) + ", " + describe(poly, p));
        const Basis b = basis(poly, p);
        std::vector<double> expected(2 * n, 0.0);
        expected[i] = (1 - t) * (1 - 2 * t);
        expected[(i + 1) % n] = t * (2 * t - 1);
        expected[n + i] = 4 * t * (1 - t);
        for (std::size_t k = 0; k < 2 * n; ++k) EXPECT_NEAR(b.psi[k], expected[k], 1e-7) << "k = " << k;
      }
    }
  }
}

TEST(PolyfemElement, TriangleIsP2Lagrange) {
  for (const Polygon& poly : polygons()) {
    if (poly.size() != 3) continue;
    EXPECT_TRUE(warp::serendipity_coefficients(poly).empty());
    const double area = warp::signed_area2(poly[0], poly[1], poly[2]);
    for (const Point& p : inside_points(poly, 20)) {
      SCOPED_TRACE(describe(poly, p));
      const double l[3] = {warp::signed_area2(p, poly[1], poly[2]) / area, warp::signed_area2(poly[0], p, poly[2]) / area,
                           warp::signed_area2(poly[0], poly[1], p) / area};
      const Basis b = basis(poly, p);
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(b.psi[i], l[i] * (2 * l[i] - 1), 1e-12);
        EXPECT_NEAR(b.psi[3 + i], 4 * l[i] * l[(i + 1) % 3], 1e-12);
      }
    }
  }
}

// Both gradients against central differences, h = 1e-6·diameter, away from the boundary.
TEST(PolyfemElement, GradientsMatchFiniteDifferences) {
  for (const Polygon& poly : polygons()) {
    const double h = 1e-6 * diameter(poly);
    for (const Point& p : inside_points(poly, 10, 0.9)) {
      SCOPED_TRACE(describe(poly, p));
      std::vector<double> lambda, lambda_plus, lambda_minus;
      std::vector<Point> lambda_gradient, unused;
      warp::mean_value_coordinates(poly, p, lambda, lambda_gradient);
      const Basis b = basis(poly, p);
      for (int axis = 0; axis < 2; ++axis) {
        const Point plus{p.x + (axis == 0 ? h : 0), p.y + (axis == 1 ? h : 0)};
        const Point minus{p.x - (axis == 0 ? h : 0), p.y - (axis == 1 ? h : 0)};
        warp::mean_value_coordinates(poly, plus, lambda_plus, unused);
        warp::mean_value_coordinates(poly, minus, lambda_minus, unused);
        for (std::size_t i = 0; i < poly.size(); ++i) {
          const double analytic = axis == 0 ? lambda_gradient[i].x : lambda_gradient[i].y;
          EXPECT_NEAR(analytic, (lambda_plus[i] - lambda_minus[i]) / (2 * h), 1e-6 * std::max(1.0, std::abs(analytic)))
              << "λ_" << i << ", axis " << axis;
        }
        const Basis bp = basis(poly, plus), bm = basis(poly, minus);
        for (std::size_t k = 0; k < b.psi.size(); ++k) {
          const double analytic = axis == 0 ? b.gradient[k].x : b.gradient[k].y;
          EXPECT_NEAR(analytic, (bp.psi[k] - bm.psi[k]) / (2 * h), 1e-6 * std::max(1.0, std::abs(analytic)))
              << "ψ_" << k << ", axis " << axis;
        }
      }
    }
  }
}

// [PolyFEM eq. 1] as printed: unsigned lengths |I_i v_ij|, |I_j v_ij|, |I_i I_j| (and eq. 1's
// factor 2 left out, so only the lengths differ from the library's coefficients).
std::vector<warp::SerendipityDiagonal> printed_coefficients(const Polygon& poly) {
  const int n = int(poly.size());
  auto v = [&](int k) { return poly[(k + n) % n]; };
  // line(a, b) ∩ line(c, d)
  auto intersect = [](const Point& a, const Point& b, const Point& c, const Point& d) {
    const double t = ((c.x - a.x) * (d.y - c.y) - (c.y - a.y) * (d.x - c.x)) /
                     ((b.x - a.x) * (d.y - c.y) - (b.y - a.y) * (d.x - c.x));
    return lerp(a, b, t);
  };
  std::vector<warp::SerendipityDiagonal> out = warp::serendipity_coefficients(poly);
  for (warp::SerendipityDiagonal& d : out) {
    const int i = d.i, j = d.j;
    const double L = distance(v(i), v(j));
    const Point m = lerp(v(i), v(j), 0.5);
    const Point Ii = intersect(v(i), v(j), v(i - 1), v(i + 1)), Ij = intersect(v(i), v(j), v(j - 1), v(j + 1));
    const double s = L / (L - distance(Ii, Ij));
    const double span_i = distance(v(i - 1), v(i + 1)), span_j = distance(v(j - 1), v(j + 1));
    d = {i, j, -s * (1 + 2 * distance(Ii, m) / L), -s * (1 + 2 * distance(Ij, m) / L),
         s * distance(Ii, v(i + 1)) / span_i, s * distance(Ii, v(i - 1)) / span_i,
         s * distance(Ij, v(j + 1)) / span_j, s * distance(Ij, v(j - 1)) / span_j};
  }
  return out;
}

double basis_sum(const Polygon& poly, const std::vector<warp::SerendipityDiagonal>& diagonals, const Point& p) {
  std::vector<double> psi;
  std::vector<Point> gradient;
  warp::serendipity_basis(poly, diagonals, p, psi, gradient);
  double sum = 0;
  for (double v : psi) sum += v;
  return sum;
}

// The regression: the printed unsigned lengths lose constant reproduction on the kite, where I_2
// lies past the midpoint of diagonal (v_0, v_2); the signed ones keep it. Where no I passes a
// midpoint (a square, a regular hexagon) both are the same coefficients.
TEST(PolyfemElement, UnsignedLengthsFailOnKite) {
  const Polygon k = kite();
  const Point p = centroid(k);
  EXPECT_NEAR(basis_sum(k, warp::serendipity_coefficients(k), p), 1, 1e-12);
  EXPECT_GT(std::abs(basis_sum(k, printed_coefficients(k), p) - 1), 1e-2);

  Polygon hexagon;
  for (int i = 0; i < 6; ++i) hexagon.push_back({std::cos(i * std::numbers::pi / 3), std::sin(i * std::numbers::pi / 3)});
  for (const Polygon& poly : {Polygon{{0, 0}, {1, 0}, {1, 1}, {0, 1}}, hexagon}) {
    const auto signed_c = warp::serendipity_coefficients(poly), printed = printed_coefficients(poly);
    ASSERT_EQ(signed_c.size(), printed.size());
    for (std::size_t d = 0; d < printed.size(); ++d) {
      EXPECT_NEAR(signed_c[d].c_ii, printed[d].c_ii, 1e-12);
      EXPECT_NEAR(signed_c[d].c_jj, printed[d].c_jj, 1e-12);
      EXPECT_NEAR(signed_c[d].c_i_prev, printed[d].c_i_prev, 1e-12);
      EXPECT_NEAR(signed_c[d].c_i_next, printed[d].c_i_next, 1e-12);
      EXPECT_NEAR(signed_c[d].c_j_prev, printed[d].c_j_prev, 1e-12);
      EXPECT_NEAR(signed_c[d].c_j_next, printed[d].c_j_next, 1e-12);
    }
  }
}

TEST(PolyfemElement, RejectsDegenerateAndNonConvexPolygons) {
  EXPECT_THROW(warp::serendipity_coefficients({{0, 0}, {1, 0}}), std::invalid_argument);
  EXPECT_THROW(warp::serendipity_coefficients({{0, 0}, {2, 0}, {1, 0.2}, {2, 2}, {0, 2}}), std::invalid_argument);
  EXPECT_THROW(warp::serendipity_coefficients({{0, 0}, {1, 0}, {2, 0}, {1, 1}}), std::invalid_argument);
  EXPECT_EQ(warp::serendipity_coefficients({{0, 0}, {1, 0}, {1, 1}, {0, 1}}).size(), 2u);
}

}  // namespace
}  // namespace zoomwarp
