// method=polyfem's global system (warp/methods/polyfem/polyfem_system.h) on a hand-made polygon
// mesh — a jittered quad grid with some quads split into triangles, so both element kinds meet:
// the nodes (vertices and edge midpoints), the patch test (constant saliency: the exact linear
// stretch, g_x = x/W and g_y = y/H at every node), the two precomputed solves combining into the
// direct solve of any target, the identity at the source size bit for bit, and a salient region
// squeezed less than the rest; and its export (polyfem_export.h): the sampled triangles tile the
// rectangle and its warp without a crack or a fold, and their chords stay within 0.5 px of the
// deformation from a small subdivision level on.
#include "warp/methods/polyfem/polyfem_system.h"
#include "warp/methods/polyfem/polyfem_export.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>

namespace zoomwarp {
namespace {

using warp::Point;

constexpr double kW = 200, kH = 120;

// 10 × 6 quads of 20 px, interior vertices jittered by up to 3 px, every third quad split along
// a diagonal: CCW cells (y down) as polygon_mesh.h requires.
warp::PolygonMesh jittered_mesh() {
  warp::PolygonMesh m;
  m.width = kW;
  m.height = kH;
  std::mt19937 rng(15);
  std::uniform_real_distribution<double> jitter(-3, 3);
  const int nx = 10, ny = 6;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      Point p{kW * i / nx, kH * j / ny};
      if (i > 0 && i < nx) p.x += jitter(rng);
      if (j > 0 && j < ny) p.y += jitter(rng);
      m.vertices.push_back(p);
    }
  const auto id = [&](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if ((i + j) % 3 == 0) {
        m.cells.push_back({a, b, c});
        m.cells.push_back({a, c, d});
      } else {
        m.cells.push_back({a, b, c, d});
      }
    }
  return m;
}

// A bright disc of radius 25 at (100, 60) on a dark field.
warp::ScalarMap disc_saliency() {
  warp::ScalarMap s{100, 60, kW, kH, {}};
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 100; ++x)
      s.values.push_back(std::hypot(2 * x + 1 - 100.0, 2 * y + 1 - 60.0) < 25 ? 1.f : 0.f);
  return s;
}

TEST(PolyfemSystem, NodesAreTheVerticesThenOneMidpointPerEdge) {
  const warp::PolygonMesh m = jittered_mesh();
  const warp::PolyfemNodes n = warp::polyfem_nodes(m);
  std::set<std::pair<int, int>> edges;
  for (const auto& cell : m.cells)
    for (std::size_t i = 0; i < cell.size(); ++i) edges.insert(std::minmax(cell[i], cell[(i + 1) % cell.size()]));
  EXPECT_EQ(n.vertex_count, int(m.vertices.size()));
  EXPECT_EQ(n.positions.size(), m.vertices.size() + edges.size());
  for (std::size_t c = 0; c < m.cells.size(); ++c) {
    ASSERT_EQ(n.cell_nodes[c].size(), 2 * m.cells[c].size());
    for (std::size_t i = 0; i < m.cells[c].size(); ++i) {
      const Point a = m.vertices[m.cells[c][i]], b = m.vertices[m.cells[c][(i + 1) % m.cells[c].size()]];
      const Point mid = n.positions[n.cell_nodes[c][m.cells[c].size() + i]];
      EXPECT_NEAR(mid.x, (a.x + b.x) / 2, 1e-12);
      EXPECT_NEAR(mid.y, (a.y + b.y) / 2, 1e-12);
    }
  }
}

// The patch test: with constant saliency the minimiser is the linear stretch, which the
// quadratic elements contain; with the consistency correction it is met exactly (to rounding),
// at a coarse quadrature as at a fine one.
TEST(PolyfemSystem, ConstantSaliencyGivesExactlyTheLinearStretch) {
  for (double area : {16.0, 64.0}) {
    warp::PolyfemOptions o;
    o.max_triangle_area = area;
    const warp::PolyfemSolution s = warp::solve_polyfem(jittered_mesh(), warp::ScalarMap{}, o);
    double worst = 0;
    for (std::size_t i = 0; i < s.nodes.positions.size(); ++i)
      worst = std::max({worst, std::abs(s.g_x[i] - s.nodes.positions[i].x / kW), std::abs(s.g_y[i] - s.nodes.positions[i].y / kH)});
    std::printf("[ polyfem  ] patch test at %.0f px² quadrature triangles: |g - linear| %.2e\n", area, worst);
    EXPECT_LT(worst, 1e-10) << area;
  }
}

TEST(PolyfemSystem, TheTwoSolvesCombineIntoTheDirectSolve) {
  const warp::PolygonMesh m = jittered_mesh();
  const warp::ScalarMap sal = disc_saliency();
  const warp::PolyfemSolution s = warp::solve_polyfem(m, sal);
  for (auto [tw, th] : {std::pair{100.0, 120.0}, {300.0, 84.0}, {150.0, 160.0}}) {
    const std::vector<Point> axpy = warp::polyfem_positions(s, kW, kH, tw, th);
    const std::vector<Point> direct = warp::solve_polyfem_direct(m, sal, tw, th);
    ASSERT_EQ(axpy.size(), direct.size());
    double worst = 0;
    for (std::size_t i = 0; i < axpy.size(); ++i)
      worst = std::max(worst, std::hypot(axpy[i].x - direct[i].x, axpy[i].y - direct[i].y));
    EXPECT_LT(worst, 1e-9 * (tw + th)) << tw << " x " << th;
  }
}

TEST(PolyfemSystem, TheSourceSizeIsTheIdentityBitForBit) {
  const warp::PolyfemSolution s = warp::solve_polyfem(jittered_mesh(), disc_saliency());
  const std::vector<Point> q = warp::polyfem_positions(s, kW, kH, kW, kH);
  for (std::size_t i = 0; i < q.size(); ++i) {
    EXPECT_EQ(q[i].x, s.nodes.positions[i].x);
    EXPECT_EQ(q[i].y, s.nodes.positions[i].y);
  }
}

// Halving the width: across the salient disc, nodes keep more than half their distance (the
// background takes more of the squeeze), and the boundary nodes sit on the target rectangle.
TEST(PolyfemSystem, TheSalientRegionIsSqueezedLessThanTheRest) {
  const warp::PolyfemSolution s = warp::solve_polyfem(jittered_mesh(), disc_saliency());
  const std::vector<Point> q = warp::polyfem_positions(s, kW, kH, kW / 2, kH);
  int left = -1, right = -1;  // the nodes nearest (85, 60) and (115, 60)
  double dl = 1e9, dr = 1e9;
  for (std::size_t i = 0; i < q.size(); ++i) {
    const Point p = s.nodes.positions[i];
    if (std::hypot(p.x - 85, p.y - 60) < dl) dl = std::hypot(p.x - 85, p.y - 60), left = int(i);
    if (std::hypot(p.x - 115, p.y - 60) < dr) dr = std::hypot(p.x - 115, p.y - 60), right = int(i);
    if (p.x == 0) {
      EXPECT_EQ(q[i].x, 0);
    }
    if (p.x == kW) {
      EXPECT_NEAR(q[i].x, kW / 2, 1e-12);
    }
  }
  const double before = s.nodes.positions[right].x - s.nodes.positions[left].x, after = q[right].x - q[left].x;
  std::printf("[ polyfem  ] width halved: across the disc %.2f px -> %.2f px (x%.3f; the uniform stretch: x0.5)\n",
              before, after, after / before);
  EXPECT_GT(after / before, 0.6);
}

double area_sum(const warp::Mesh& m, const std::vector<Point>& q) {
  double a = 0;
  for (const auto& t : m.triangles) a += warp::signed_area2(q[t[0]], q[t[1]], q[t[2]]) / 2;
  return a;
}

// The samples tile the rectangle (each interior edge in two triangles, the area W·H, all CCW),
// and their warp tiles the target rectangle without a fold at a moderate squeeze (width × 0.8).
// (Halving the width folds the linear solution beside the stiff disc: the case [PolyFEM §4.5]'s
// L-BFGS with per-cell rollback is for, not built yet.)
// Every cell sampled alone, the samplings concatenated as a view emits them: samples on a shared
// edge are computed by both cells and must coincide bit for bit in the source and in the warp.
struct Joined {
  warp::Mesh source;
  std::vector<Point> warped;
};
Joined join_cells(const warp::PolygonMesh& m, const warp::PolyfemSolution& s, int level, double dw, double dh) {
  std::vector<Point> d(s.g_x.size());
  for (std::size_t k = 0; k < d.size(); ++k) d[k] = {dw * s.g_x[k], dh * s.g_y[k]};
  Joined out;
  for (int c = 0; c < int(m.cells.size()); ++c) {
    const warp::CellSampling cell = warp::sample_polyfem_cell(m, s.nodes, c, level);
    EXPECT_EQ(long(cell.triangles.size()), warp::polyfem_cell_triangles(m, c, level));
    const int base = int(out.source.vertices.size());
    out.source.vertices.insert(out.source.vertices.end(), cell.source.begin(), cell.source.end());
    warp::displace_cell_samples(cell, d, out.warped);
    for (const auto& t : cell.triangles) out.source.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
  return out;
}

TEST(PolyfemExport, CellsSampledAloneTileTheSourceAndTheTargetWithoutCracks) {
  const warp::PolygonMesh m = jittered_mesh();
  const warp::PolyfemSolution s = warp::solve_polyfem(m, disc_saliency());
  for (int level : {0, 1, 3}) {
    const Joined j = join_cells(m, s, level, -0.2 * kW, 0);
    // Weld by exact source position: each interior edge must be used twice, a border edge once.
    std::map<std::pair<double, double>, int> weld;
    std::vector<int> id(j.source.vertices.size());
    for (std::size_t i = 0; i < id.size(); ++i) {
      const Point p = j.source.vertices[i];
      auto [it, inserted] = weld.emplace(std::make_pair(p.x, p.y), int(i));
      id[i] = it->second;
      EXPECT_EQ(j.warped[i].x, j.warped[it->second].x) << "a crack at level " << level;
      EXPECT_EQ(j.warped[i].y, j.warped[it->second].y) << "a crack at level " << level;
    }
    std::map<std::pair<int, int>, int> uses;
    for (const auto& t : j.source.triangles) {
      EXPECT_GT(warp::signed_area2(j.source.vertices[t[0]], j.source.vertices[t[1]], j.source.vertices[t[2]]), 0);
      EXPECT_GT(warp::signed_area2(j.warped[t[0]], j.warped[t[1]], j.warped[t[2]]), 0) << level;
      for (int k = 0; k < 3; ++k) ++uses[std::minmax(id[t[k]], id[t[(k + 1) % 3]])];
    }
    for (const auto& [edge, n] : uses) {
      const Point a = j.source.vertices[edge.first], b = j.source.vertices[edge.second];
      const bool border = (a.x == 0 && b.x == 0) || (a.y == 0 && b.y == 0) || (a.x == kW && b.x == kW) || (a.y == kH && b.y == kH);
      EXPECT_EQ(n, border ? 1 : 2) << "level " << level << ": a crack or an overlap at (" << a.x << ", " << a.y << ")";
    }
    EXPECT_NEAR(area_sum(j.source, j.source.vertices), kW * kH, 1e-9 * kW * kH) << level;
    EXPECT_NEAR(area_sum(j.source, j.warped), 0.8 * kW * kH, 1e-9 * kW * kH) << level;
  }
}

TEST(PolyfemExport, NoDisplacementIsTheIdentityBitForBit) {
  const warp::PolygonMesh m = jittered_mesh();
  const warp::PolyfemSolution s = warp::solve_polyfem(m, disc_saliency());
  const Joined j = join_cells(m, s, 2, 0, 0);
  for (std::size_t i = 0; i < j.warped.size(); ++i) {
    EXPECT_EQ(j.warped[i].x, j.source.vertices[i].x);
    EXPECT_EQ(j.warped[i].y, j.source.vertices[i].y);
  }
}

// The chord error: the straight chord of a level-k edge misses the deformation at the edge's
// source midpoint (evaluated exactly, polyfem_point_weights) by at most δ_c·|ΔW| — the bound a
// view chooses its level by — and δ_c shrinks about fourfold per level (the field is smooth
// inside cells); below 0.5 px by level 2 with the width halved.
TEST(PolyfemExport, ChordErrorIsBoundedByTheCellDeviationAndShrinksWithTheLevel) {
  const warp::PolygonMesh m = jittered_mesh();
  const warp::PolyfemSolution s = warp::solve_polyfem(m, disc_saliency());
  const double dw = -kW / 2;
  std::vector<Point> d(s.g_x.size());
  for (std::size_t k = 0; k < d.size(); ++k) d[k] = {dw * s.g_x[k], 0};
  std::vector<double> worst(4, 0), bound(4, 0);
  for (int level = 0; level < 4; ++level)
    for (int c = 0; c < int(m.cells.size()); ++c) {
      const Point delta =
          warp::polyfem_chord_deviation(warp::sample_polyfem_cell(m, s.nodes, c, level + 1), warp::polyfem_g_field(s));
      bound[level] = std::max(bound[level], std::abs(dw) * delta.x);
      const warp::CellSampling cell = warp::sample_polyfem_cell(m, s.nodes, c, level);
      std::vector<Point> q;
      warp::displace_cell_samples(cell, d, q);
      for (const auto& t : cell.triangles)
        for (int k = 0; k < 3; ++k) {
          const int a = t[k], b = t[(k + 1) % 3];
          const Point mid{(cell.source[a].x + cell.source[b].x) / 2, (cell.source[a].y + cell.source[b].y) / 2};
          std::vector<int> node;
          std::vector<double> weight;
          warp::polyfem_point_weights(m, s.nodes, c, mid, node, weight);
          Point f = mid;
          for (std::size_t w = 0; w < node.size(); ++w) f = {f.x + weight[w] * d[node[w]].x, f.y + weight[w] * d[node[w]].y};
          const double miss = std::hypot((q[a].x + q[b].x) / 2 - f.x, (q[a].y + q[b].y) / 2 - f.y);
          EXPECT_LE(miss, std::abs(dw) * delta.x + 1e-9) << "cell " << c << " level " << level;
          worst[level] = std::max(worst[level], miss);
        }
    }
  std::printf("[ polyfem  ] chord error, width halved: %.3f / %.3f / %.3f / %.3f px at levels 0–3 (bounds %.3f … %.3f)\n",
              worst[0], worst[1], worst[2], worst[3], bound[0], bound[3]);
  for (int level = 1; level < 4; ++level) EXPECT_LT(worst[level], worst[level - 1] / 2.5) << level;
  EXPECT_LT(worst[2], 0.5);
}

// The model's δ_c of levels 0–3 from one sampling at level 4 (polyfem_chord_deviations) are those
// of sampling each level on its own, to the bit: the finer lattice holds the coarser ones' points.
TEST(PolyfemExport, ChordDeviationsOfAllLevelsAtOnceAreEachLevelsOwn) {
  const warp::PolygonMesh m = jittered_mesh();
  const warp::PolyfemSolution s = warp::solve_polyfem(m, disc_saliency());
  const std::vector<Point> g = warp::polyfem_g_field(s);
  for (int c = 0; c < int(m.cells.size()); ++c) {
    const std::vector<Point> all = warp::polyfem_chord_deviations(m, s.nodes, c, 4, g);
    ASSERT_EQ(all.size(), 4u);
    for (int level = 0; level < 4; ++level) {
      const Point own = warp::polyfem_chord_deviation(warp::sample_polyfem_cell(m, s.nodes, c, level + 1), g);
      EXPECT_EQ(all[level].x, own.x) << "cell " << c << " level " << level;
      EXPECT_EQ(all[level].y, own.y) << "cell " << c << " level " << level;
    }
  }
  EXPECT_THROW(warp::polyfem_chord_deviations(m, s.nodes, 0, 0, g), std::invalid_argument);
}

// A constant saliency gives the exact stretch (G = x/W, y/H): no aspect folds it.
TEST(PolyfemSystem, TheStretchIsFoldFreeAtEveryAspect) {
  const warp::PolygonMesh m = jittered_mesh();
  warp::ScalarMap flat{10, 6, kW, kH, std::vector<float>(60, 0.5f)};
  const warp::AspectRange range = warp::polyfem_fold_free_range(m, warp::solve_polyfem(m, flat));
  EXPECT_LT(range.low, 1e-6);
  EXPECT_EQ(range.high, warp::AspectRange::kUnboundedAspect);
}

}  // namespace
}  // namespace zoomwarp
