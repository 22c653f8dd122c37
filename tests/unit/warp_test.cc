// The warp engine's first layers: the coarsest mesh (CGAL) and the local–global shape warp
// (CHOLMOD), checked for the properties a viewer would notice: no fold-overs, the rectangle
// exactly covered, boundaries on the target boundary, straight lines, significance respected.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <unordered_map>

#include "warp/meshing/coarse_mesh.h"
#include "warp/icaz/edge_map.h"
#include "warp/icaz/shape_warp.h"

namespace zoomwarp {
namespace {

using warp::Point;

// Every edge is shared by two triangles, except edges on the rectangle's boundary (one).
void expect_conforming(const warp::Mesh& m, double w, double h) {
  std::map<std::pair<int, int>, int> edges;
  double area = 0;
  for (const auto& t : m.triangles) {
    const double a = 0.5 * warp::signed_area2(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]);
    ASSERT_GT(a, 0) << "inverted or degenerate triangle";
    area += a;
    for (int k = 0; k < 3; ++k) {
      int i = t[k], j = t[(k + 1) % 3];
      ++edges[{std::min(i, j), std::max(i, j)}];
    }
  }
  EXPECT_NEAR(area, w * h, 1e-6 * w * h);
  for (const auto& [e, n] : edges) {
    const Point &a = m.vertices[e.first], &b = m.vertices[e.second];
    const bool on_boundary = (a.x == 0 && b.x == 0) || (a.x == w && b.x == w) || (a.y == 0 && b.y == 0) ||
                             (a.y == h && b.y == h);
    EXPECT_EQ(n, on_boundary ? 1 : 2) << "edge (" << a.x << "," << a.y << ")-(" << b.x << "," << b.y << ")";
  }
}

TEST(CoarseMesh, ConformingDelaunayWithinAreaAndBudget) {
  const double w = 5400, h = 2500;
  auto cm = warp::build_coarse_mesh(w, h, {});
  expect_conforming(cm.mesh, w, h);
  EXPECT_LE(int(cm.mesh.vertices.size()), 2000);
  EXPECT_GT(int(cm.mesh.vertices.size()), 500) << "the budget is used, not wasted";
  for (const auto& t : cm.mesh.triangles) {
    const Point &a = cm.mesh.vertices[t[0]], &b = cm.mesh.vertices[t[1]], &c = cm.mesh.vertices[t[2]];
    EXPECT_LE(0.5 * warp::signed_area2(a, b, c), cm.max_triangle_area * 1.0001);
    // Minimum angle (CGAL guarantees the bound away from input angles; the rectangle has none < 90°).
    const double la = std::hypot(b.x - c.x, b.y - c.y), lb = std::hypot(a.x - c.x, a.y - c.y),
                 lc = std::hypot(a.x - b.x, a.y - b.y);
    const double amin = std::acos(std::min(1.0, (lb * lb + lc * lc - la * la) / (2 * lb * lc)));
    const double bmin = std::acos(std::min(1.0, (la * la + lc * lc - lb * lb) / (2 * la * lc)));
    const double cmin = M_PI - amin - bmin;
    EXPECT_GE(std::min({amin, bmin, cmin}) * 180 / M_PI, 19.9);
  }
}

TEST(CoarseMesh, GigapixelStaysWithinTheVertexBudget) {
  auto cm = warp::build_coarse_mesh(48000, 24000, {{{0, 12000}, {48000, 12000}}});
  EXPECT_LE(int(cm.mesh.vertices.size()), 2000);
  expect_conforming(cm.mesh, 48000, 24000);
}

TEST(CoarseMesh, LinesBecomeChainsOfEdges) {
  const double w = 3000, h = 2000;
  const std::vector<warp::Segment> lines = {
      {{0, 1000}, {3000, 1000}},    // horizon
      {{500, -100}, {2600, 1900}},  // oblique, clipped at the top
      {{1700, 300}, {1700, 1800}},  // vertical, crossing both
      {{-50, -50}, {-10, -10}},     // outside: ignored
  };
  auto cm = warp::build_coarse_mesh(w, h, lines);
  expect_conforming(cm.mesh, w, h);
  ASSERT_EQ(cm.line_vertices.size(), 4u);
  EXPECT_TRUE(cm.line_vertices[3].empty());
  std::map<std::pair<int, int>, int> edges;
  for (const auto& t : cm.mesh.triangles)
    for (int k = 0; k < 3; ++k) edges[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}] = 1;
  for (int l = 0; l < 3; ++l) {
    const auto& ids = cm.line_vertices[l];
    ASSERT_GE(ids.size(), 2u);
    for (std::size_t k = 1; k < ids.size(); ++k)
      EXPECT_TRUE(edges.count({std::min(ids[k - 1], ids[k]), std::max(ids[k - 1], ids[k])})) << "line " << l;
  }
  EXPECT_EQ(cm.mesh.vertices[cm.line_vertices[0].front()].x, 0);
  EXPECT_EQ(cm.mesh.vertices[cm.line_vertices[0].back()].x, 3000);
  EXPECT_NEAR(cm.mesh.vertices[cm.line_vertices[1].front()].y, 0, 1e-9);  // clipped start
}

// Significance: 1 inside a central disc, 0.1 elsewhere.
std::vector<double> disc_weights(const warp::Mesh& m, Point c, double r) {
  std::vector<double> w;
  for (const auto& t : m.triangles) {
    const Point& a = m.vertices[t[0]];
    const Point& b = m.vertices[t[1]];
    const Point& d = m.vertices[t[2]];
    const Point g{(a.x + b.x + d.x) / 3, (a.y + b.y + d.y) / 3};
    w.push_back(std::hypot(g.x - c.x, g.y - c.y) < r ? 1.0 : 0.1);
  }
  return w;
}

void expect_valid_warp(const warp::Mesh& m, const std::vector<Point>& p, double w, double h, double tw, double th) {
  for (const auto& t : m.triangles) EXPECT_GT(warp::signed_area2(p[t[0]], p[t[1]], p[t[2]]), 0) << "fold-over";
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_GE(p[i].x, -1e-6);
    EXPECT_LE(p[i].x, tw + 1e-6);
    EXPECT_GE(p[i].y, -1e-6);
    EXPECT_LE(p[i].y, th + 1e-6);
    if (m.vertices[i].x == 0) {
      EXPECT_NEAR(p[i].x, 0, 1e-9);
    }
    if (m.vertices[i].x == w) {
      EXPECT_NEAR(p[i].x, tw, 1e-9);
    }
    if (m.vertices[i].y == 0) {
      EXPECT_NEAR(p[i].y, 0, 1e-9);
    }
    if (m.vertices[i].y == h) {
      EXPECT_NEAR(p[i].y, th, 1e-9);
    }
  }
}

// EdgeMap against std::unordered_map under a random mix of inserts and erases (erase shifts
// entries back, which is where open addressing goes wrong if it does).
TEST(EdgeMap, BehavesLikeAMap) {
  warp::EdgeMap map;
  std::unordered_map<std::uint64_t, std::array<int, 2>> reference;
  std::mt19937_64 rng(7);
  for (int step = 0; step < 200000; ++step) {
    const std::uint64_t key = rng() % 5000;
    if (rng() % 3 == 0 && reference.count(key)) {
      map.erase(key);
      reference.erase(key);
    } else {
      const std::array<int, 2> value{int(step), int(key)};
      const bool fresh = map.emplace(key, value).second;
      ASSERT_EQ(fresh, reference.emplace(key, value).second);
    }
    if (step % 997 == 0) {
      ASSERT_EQ(map.size(), reference.size());
      for (const auto& [k, v] : reference) {
        const auto* found = map.find(k);
        ASSERT_TRUE(found);
        ASSERT_EQ(*found, v);
      }
      for (std::uint64_t k = 5000; k < 5100; ++k) ASSERT_FALSE(map.find(k));
    }
  }
}

TEST(ShapeWarp, SameSizeIsTheIdentity) {
  auto cm = warp::build_coarse_mesh(2560, 1600, {});
  warp::ShapeWarp warp(cm.mesh, disc_weights(cm.mesh, {1280, 800}, 400), 2560, 1600);
  EXPECT_TRUE(warp.factored_once());
  auto r = warp.solve(2560, 1600);
  EXPECT_TRUE(r.converged);
  for (std::size_t i = 0; i < r.positions.size(); ++i) {
    EXPECT_NEAR(r.positions[i].x, cm.mesh.vertices[i].x, 1e-6);
    EXPECT_NEAR(r.positions[i].y, cm.mesh.vertices[i].y, 1e-6);
  }
}

// A local solve (icaz.h): pinning part of a converged warp at its own positions and solving again
// changes nothing, and pinned vertices never move even from a start far from the optimum.
TEST(ShapeWarp, PinnedVerticesHoldTheirInitialPositions) {
  const double w = 4000, h = 1500, tw = 1500, th = 1500;
  auto cm = warp::build_coarse_mesh(w, h, {});
  const auto weights = disc_weights(cm.mesh, {2000, 750}, 450);
  const auto whole = warp::ShapeWarp(cm.mesh, weights, w, h).solve(tw, th);
  std::vector<int> pinned;
  for (std::size_t i = 0; i < cm.mesh.vertices.size(); ++i)
    if (cm.mesh.vertices[i].x < 1000 || cm.mesh.vertices[i].x > 3000) pinned.push_back(int(i));
  const warp::ShapeWarp local(cm.mesh, weights, w, h, {}, pinned);
  const auto again = local.solve(tw, th, {}, whole.positions);
  for (std::size_t i = 0; i < whole.positions.size(); ++i) {
    EXPECT_NEAR(again.positions[i].x, whole.positions[i].x, 0.05);
    EXPECT_NEAR(again.positions[i].y, whole.positions[i].y, 0.05);
  }
  std::vector<Point> uniform;
  for (const Point& p : cm.mesh.vertices) uniform.push_back({p.x * tw / w, p.y * th / h});
  const auto from_uniform = local.solve(tw, th, {}, uniform);
  EXPECT_EQ(from_uniform.inverted, 0);
  for (int i : pinned) {
    EXPECT_EQ(from_uniform.positions[i].x, uniform[i].x);
    EXPECT_EQ(from_uniform.positions[i].y, uniform[i].y);
  }
  EXPECT_THROW(local.solve(tw, th), std::invalid_argument) << "pinned vertices need initial positions";
}

TEST(ShapeWarp, SignificantRegionKeepsItsShapeWhenSqueezed) {
  const double w = 4000, h = 1500, tw = 1500, th = 1500;  // a wide image squeezed to a square
  auto cm = warp::build_coarse_mesh(w, h, {});
  warp::ShapeWarp warp(cm.mesh, disc_weights(cm.mesh, {2000, 750}, 450), w, h);
  auto r = warp.solve(tw, th);
  EXPECT_TRUE(r.converged) << r.iterations;
  expect_valid_warp(cm.mesh, r.positions, w, h, tw, th);
  // The disc's vertices: their spread in x vs y stays near 1:1, and it is shown larger than
  // uniform squeezing would (1500/4000 = 0.375 in x).
  double minx = 1e9, maxx = -1e9, miny = 1e9, maxy = -1e9;
  for (std::size_t i = 0; i < r.positions.size(); ++i)
    if (std::hypot(cm.mesh.vertices[i].x - 2000, cm.mesh.vertices[i].y - 750) < 400) {
      minx = std::min(minx, r.positions[i].x), maxx = std::max(maxx, r.positions[i].x);
      miny = std::min(miny, r.positions[i].y), maxy = std::max(maxy, r.positions[i].y);
    }
  const double sx = (maxx - minx) / 800, sy = (maxy - miny) / 800;
  EXPECT_GT(sx, 0.375 * 1.5) << "the disc keeps more width than a uniform squeeze";
  EXPECT_LT(std::abs(sx / sy - 1), 0.25) << "and stays roughly round: sx " << sx << " sy " << sy;
}

TEST(ShapeWarp, LinesStayStraight) {
  const double w = 4000, h = 2000, tw = 1800, th = 1600;
  const std::vector<warp::Segment> lines = {{{0, 1200}, {4000, 1200}}, {{600, 200}, {3400, 1900}}};
  auto cm = warp::build_coarse_mesh(w, h, lines);
  warp::ShapeWarp warp(cm.mesh, disc_weights(cm.mesh, {1000, 600}, 500), w, h, cm.line_vertices);
  EXPECT_FALSE(warp.factored_once());
  auto r = warp.solve(tw, th);
  EXPECT_EQ(r.inverted, 0);
  expect_valid_warp(cm.mesh, r.positions, w, h, tw, th);
  // Horizon: one y. Oblique line: every vertex within 1 px of the chord.
  const auto& horizon = cm.line_vertices[0];
  for (int i : horizon) EXPECT_NEAR(r.positions[i].y, r.positions[horizon[0]].y, 0.5);
  const auto& oblique = cm.line_vertices[1];
  const Point a = r.positions[oblique.front()], b = r.positions[oblique.back()];
  for (int i : oblique) {
    const Point& p = r.positions[i];
    const double dist = std::abs((p.x - a.x) * (b.y - a.y) - (p.y - a.y) * (b.x - a.x)) / std::hypot(b.x - a.x, b.y - a.y);
    EXPECT_LT(dist, 1.0);
  }
}

}  // namespace
}  // namespace zoomwarp
