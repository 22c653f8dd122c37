// The comparison metrics (warp/compare/metrics.h) on synthetic meshes with known answers, and
// then on the samples for icaz, traditional and retarget-zoom: no fold-overs and a covered screen
// for the retargeting methods, with the table printed.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/compare/metrics.h"
#include "warp/core/uniform_zoom.h"
#include "warp/icaz/icaz.h"
#include "warp/methods/retarget_zoom/retarget_zoom.h"

namespace zoomwarp {
namespace {

using warp::Point;

// A (n+1)×(n+1)-vertex grid over [0, size]², two triangles per cell, drawn on screen by `to`.
warp::View grid_view(int n, double size, const std::function<Point(Point)>& to) {
  warp::View v;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) v.source.vertices.push_back({size * x / n, size * y / n});
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      v.source.triangles.push_back({a, b, d});
      v.source.triangles.push_back({a, d, c});
    }
  for (const Point& p : v.source.vertices) v.screen.push_back(to(p)), v.warped.push_back(to(p));
  for (int f = 0; f < int(v.source.triangles.size()); ++f) v.visible.push_back(f);
  return v;
}

// The same grid with every triangle on vertices of its own, drawn on screen by `to(p, centroid)`:
// neighbouring triangles may be drawn by different maps (a torn view, for piecewise tests).
warp::View torn_grid_view(int n, double size, const std::function<Point(Point, Point)>& to) {
  const warp::View grid = grid_view(n, size, [](Point p) { return p; });
  warp::View v;
  for (const warp::Triangle& t : grid.source.triangles) {
    const Point &a = grid.source.vertices[t[0]], &b = grid.source.vertices[t[1]], &c = grid.source.vertices[t[2]];
    const Point centroid{(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3};
    const int base = int(v.source.vertices.size());
    for (const Point& p : {a, b, c}) v.source.vertices.push_back(p), v.screen.push_back(to(p, centroid));
    v.source.triangles.push_back({base, base + 1, base + 2});
  }
  v.warped = v.screen;
  for (int f = 0; f < int(v.source.triangles.size()); ++f) v.visible.push_back(f);
  return v;
}

// p turned by `degrees` about `centre` (+x towards +y), then moved by `shift`.
Point turned(Point p, Point centre, double degrees, Point shift = {0, 0}) {
  const double t = degrees * std::numbers::pi / 180, c = std::cos(t), s = std::sin(t);
  const double x = p.x - centre.x, y = p.y - centre.y;
  return {centre.x + c * x - s * y + shift.x, centre.y + s * x + c * y + shift.y};
}

// A map of the square [0, size]² at one map pixel per image pixel, all of one value: the salient
// tenth is its top tenth of rows (ties by position), the mass spread evenly.
warp::SignificanceMap flat_map(int size) {
  warp::SignificanceMap m;
  m.width = m.height = size, m.scale = 1;
  m.values.assign(std::size_t(size) * size, 0.5f);
  return m;
}

// A map of the square [0, size]² at one map pixel per image pixel, with a bright block.
warp::SignificanceMap block_map(int size) {
  warp::SignificanceMap m;
  m.width = m.height = size, m.scale = 1;
  m.values.assign(std::size_t(size) * size, 0.1f);
  for (int y = size / 4; y < size / 2; ++y)
    for (int x = size / 4; x < size / 2; ++x) m.values[std::size_t(y) * size + x] = 0.9f;
  return m;
}

TEST(Metrics, IdentityGivesUnitGainUnitAnisotropyNoFoldsFullCoverage) {
  const warp::View v = grid_view(4, 100, [](Point p) { return p; });
  const auto m = warp::mesh_view_metrics(v, v, block_map(100), {{{0, 30}, {100, 30}}}, 100, 100);
  EXPECT_DOUBLE_EQ(*m.scale_gain, 1);
  EXPECT_NEAR(*m.anisotropy_salient, 1, 1e-12);
  EXPECT_NEAR(*m.anisotropy_weighted, 1, 1e-12);
  EXPECT_EQ(*m.folds, 0);
  EXPECT_DOUBLE_EQ(m.coverage, 1);
  EXPECT_NEAR(*m.straightness, 0, 1e-9);
}

TEST(Metrics, AnAffineStretchHasItsRatioAsAnisotropyAndItsAreaAsGain) {
  // x × 2, y × 0.5: σ1/σ2 = 4 everywhere; against the identity on the same (200 × 100) screen,
  // everything salient is shown at the same area (det 1), and all of it is on screen.
  const warp::View stretched = grid_view(4, 100, [](Point p) { return Point{2 * p.x, 0.5 * p.y}; });
  const warp::View identity = grid_view(4, 100, [](Point p) { return p; });
  auto m = warp::mesh_view_metrics(stretched, identity, block_map(100), {}, 200, 100);
  EXPECT_NEAR(*m.anisotropy_salient, 4, 1e-12);
  EXPECT_NEAR(*m.anisotropy_weighted, 4, 1e-12);
  EXPECT_NEAR(*m.scale_gain, 1, 1e-12);
  EXPECT_FALSE(m.straightness) << "no lines: not applicable";
  // A magnification by 2 in x alone doubles the salient area (and has anisotropy 2).
  const warp::View wide = grid_view(4, 100, [](Point p) { return Point{2 * p.x, p.y}; });
  m = warp::mesh_view_metrics(wide, identity, block_map(100), {}, 200, 100);
  EXPECT_NEAR(*m.scale_gain, 2, 1e-12);
  EXPECT_NEAR(*m.anisotropy_salient, 2, 1e-12);
  // A rotation keeps shapes: anisotropy 1.
  EXPECT_NEAR(warp::anisotropy({0, 0}, {1, 0}, {0, 1}, {0, 0}, {0.6, 0.8}, {-0.8, 0.6}), 1, 1e-12);
}

// A map of the square [0, size]² at one map pixel per image pixel: 1 on the columns x < size / 5,
// 0 elsewhere — its top fifth is exactly those columns.
warp::SignificanceMap left_fifth_map(int size) {
  warp::SignificanceMap m;
  m.width = m.height = size, m.scale = 1;
  m.values.assign(std::size_t(size) * size, 0.0f);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size / 5; ++x) m.values[std::size_t(y) * size + x] = 1.0f;
  return m;
}

// Issue 41's squash measures: a uniform stretch has its ratio at every percentile and shows all;
// a crop has anisotropy 1 and shows the share of the salient mass it keeps.
TEST(Metrics, SquashOfAStretchIsItsRatioAndOfACropItsShare) {
  const warp::View stretched = grid_view(4, 100, [](Point p) { return Point{2 * p.x, 0.5 * p.y}; });
  auto sq = warp::squash_measures(stretched, left_fifth_map(100), 200, 50);
  EXPECT_NEAR(*sq.anisotropy_p90, 4, 1e-12);
  EXPECT_NEAR(*sq.anisotropy_p99, 4, 1e-12);
  EXPECT_DOUBLE_EQ(*sq.coverage, 1);
  // The same stretch through mesh_view_metrics, against the map it is given.
  const auto m = warp::mesh_view_metrics(stretched, stretched, left_fifth_map(100), {}, 200, 50);
  EXPECT_NEAR(*m.squash.anisotropy_p99, 4, 1e-12);
  // The right half on a 50 px wide screen: nothing salient shown.
  const warp::View right = grid_view(4, 100, [](Point p) { return Point{p.x - 50, p.y}; });
  sq = warp::squash_measures(right, left_fifth_map(100), 50, 100);
  EXPECT_DOUBLE_EQ(*sq.coverage, 0);
  EXPECT_FALSE(sq.anisotropy_p90) << "nothing salient on screen";
  // The left 10 columns: half the salient mass, undistorted.
  const warp::View left = grid_view(4, 100, [](Point p) { return p; });
  sq = warp::squash_measures(left, left_fifth_map(100), 10, 100);
  EXPECT_NEAR(*sq.coverage, 0.5, 1e-12);
  EXPECT_NEAR(*sq.anisotropy_p90, 1, 1e-12);
  // One triangle of the salient part squeezed flat (a tear) shows at p99 but not at p90.
  warp::View torn = torn_grid_view(10, 100, [](Point p, Point centroid) {
    return centroid.x < 10 && centroid.y < 10 ? Point{p.x, 5 + (p.y - 5) * 0.01} : p;
  });
  sq = warp::squash_measures(torn, left_fifth_map(100), 100, 100);
  EXPECT_NEAR(*sq.anisotropy_p90, 1, 1e-9);
  EXPECT_GT(*sq.anisotropy_p99, 50);
  // An empty map measures nothing.
  EXPECT_FALSE(warp::squash_measures(left, {}, 100, 100).coverage);
}

TEST(Metrics, SquashOfARasterMethodIsItsCoverage) {
  // A 20 × 100 screen showing the image's columns 0…19 one to one: all of the salient fifth.
  std::vector<Point> sources;
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 20; ++x) sources.push_back({x + 0.5, y + 0.5});
  EXPECT_NEAR(*warp::squash_measures_of_sources(sources, left_fifth_map(100)).coverage, 1, 1e-12);
  for (Point& p : sources) p.x += 50;
  EXPECT_NEAR(*warp::squash_measures_of_sources(sources, left_fifth_map(100)).coverage, 0, 1e-12);
  for (Point& p : sources) p = {std::nan(""), std::nan("")};
  EXPECT_NEAR(*warp::squash_measures_of_sources(sources, left_fifth_map(100)).coverage, 0, 1e-12);
}

TEST(Metrics, ARigidRotationHasItsAngleAsRotationAndNoSpread) {
  // The whole view turned by 10° about its centre (onto the middle of a 200 × 200 screen): every
  // triangle turns by 10°, which bends nothing.
  const warp::View v = grid_view(4, 100, [](Point p) { return turned(p, {50, 50}, 10, {50, 50}); });
  const auto m = warp::mesh_view_metrics(v, v, block_map(100), {}, 200, 200);
  ASSERT_TRUE(m.rotation_p95 && m.rotation_spread);
  EXPECT_NEAR(*m.rotation_p95, 10, 1e-9);
  EXPECT_NEAR(*m.rotation_spread, 0, 1e-9);
  EXPECT_NEAR(*m.anisotropy_salient, 1, 1e-6) << "a rotation keeps shapes (σ1/σ2 from √(‖M‖⁴ − 4det²) ≈ √0)";
  EXPECT_NEAR(warp::rotation_degrees({0, 0}, {1, 0}, {0, 1}, {0, 0}, {0, 1}, {-1, 0}), 90, 1e-12);
  EXPECT_NEAR(warp::rotation_degrees({0, 0}, {1, 0}, {0, 1}, {0, 0}, {0.6, -0.8}, {0.8, 0.6}),
              -std::atan2(0.8, 0.6) * 180 / std::numbers::pi, 1e-12);
}

TEST(Metrics, AStretchTurnsNothing) {
  // Uniform (× 2) and anisotropic (x × 2, y × 0.5) stretches along the axes: no rotation at all.
  const warp::View identity = grid_view(4, 100, [](Point p) { return p; });
  for (const Point k : {Point{2, 2}, Point{2, 0.5}}) {
    const warp::View v = grid_view(4, 100, [k](Point p) { return Point{k.x * p.x, k.y * p.y}; });
    const auto m = warp::mesh_view_metrics(v, identity, block_map(100), {}, 200, 200);
    ASSERT_TRUE(m.rotation_p95 && m.rotation_spread);
    EXPECT_NEAR(*m.rotation_p95, 0, 1e-12);
    EXPECT_NEAR(*m.rotation_spread, 0, 1e-12);
  }
  // A shear is not a stretch: its closest rotation turns (x + 0.5y, y): atan2(−0.5, 2).
  EXPECT_NEAR(warp::rotation_degrees({0, 0}, {1, 0}, {0, 1}, {0, 0}, {1, 0}, {0.5, 1}),
              std::atan2(-0.5, 2) * 180 / std::numbers::pi, 1e-12);
}

TEST(Metrics, HalvesTurnedOppositeWaysSpreadByTheAngle) {
  // The left half turned by +8° and the right by −8° (each about its own centre): equal
  // significance mass each way, so the spread is 8° about a mean of 0 — a bend a whole-view
  // rotation does not have; every salient triangle is turned by 8°.
  const warp::View v = torn_grid_view(4, 100, [](Point p, Point centroid) {
    return centroid.x < 50 ? turned(p, {25, 50}, 8, {100, 100}) : turned(p, {75, 50}, -8, {100, 100});
  });
  const auto m = warp::mesh_view_metrics(v, v, flat_map(100), {}, 300, 300);
  ASSERT_TRUE(m.rotation_p95 && m.rotation_spread);
  EXPECT_NEAR(*m.rotation_spread, 8, 1e-9);
  EXPECT_NEAR(*m.rotation_p95, 8, 1e-9);
}

TEST(Metrics, WeightedQuantileAndSpread) {
  EXPECT_EQ(warp::weighted_quantile({{3, 90}, {1, 4}, {2, 6}}, 0.95), 3);
  EXPECT_EQ(warp::weighted_quantile({{3, 4}, {1, 90}, {2, 6}}, 0.95), 2) << "90 % at 1, 96 % at 2";
  EXPECT_TRUE(std::isnan(warp::weighted_quantile({}, 0.95)));
  EXPECT_NEAR(warp::weighted_spread({{-2, 1}, {2, 1}}), 2, 1e-15);
  EXPECT_NEAR(warp::weighted_spread({{5, 3}, {5, 1}}), 0, 1e-15);
  EXPECT_NEAR(warp::weighted_spread({{0, 3}, {4, 1}}), std::sqrt(3.0), 1e-15) << "mean 1: (3·1 + 9) / 4";
}

TEST(Metrics, AFlippedTriangleIsCounted) {
  // The centre vertex of a 2×2 grid pushed past its right neighbours' column: the triangles on
  // its right turn over.
  warp::View v = grid_view(2, 100, [](Point p) { return p; });
  v.screen[4] = {120, 50};
  EXPECT_EQ(warp::fold_count(v), 2);
  v.screen[4] = {60, 50};
  EXPECT_EQ(warp::fold_count(v), 0);
  // Collapsed onto its right neighbour: two triangles of zero area, which count as folds.
  v.screen[4] = {100, 50};
  EXPECT_EQ(warp::fold_count(v), 2);
  // Only emitted triangles count.
  v.screen[4] = {120, 50};
  v.visible = {0, 1};
  EXPECT_EQ(warp::fold_count(v), 0);
}

TEST(Metrics, ABentLineHasItsBendAsStraightnessResidual) {
  // The line y = 50 through the centre vertex, which is lifted by 3 px: the chord is y = 50.
  warp::View v = grid_view(2, 100, [](Point p) { return p; });
  v.screen[4] = {50, 47};
  const auto m = warp::mesh_view_metrics(v, v, block_map(100), {{{0, 50}, {100, 50}}}, 100, 100);
  EXPECT_NEAR(*m.straightness, 3, 1e-9);
  EXPECT_NEAR(warp::chord_deviation({{0, 0}, {5, 2}, {10, 0}}), 2, 1e-12);
}

TEST(Metrics, AKinkIsMeasuredWhereItIsNotWhereASampleFalls) {
  // A 10 × 10 image shown × 40 with its centre vertex lifted by 30 screen px: the line y = 5 from
  // x = 0.4 to 9.7 kinks at the centre vertex, (200, 170) on screen. Its bend is that point's
  // distance from the chord between its ends' screen images, whichever samples a scan would take
  // (every source pixel from x = 0.4 misses x = 5 by 0.05, 2 screen px).
  warp::View v = grid_view(2, 10, [](Point p) { return Point{40 * p.x, 40 * p.y}; });
  v.screen[4] = {200, 170};
  const Point a{0.4 * 40, 200 - 30 * 0.4 / 5}, b{9.7 * 40, 200 - 30 * 0.3 / 5};  // along the lifted edges
  const auto m = warp::mesh_view_metrics(v, v, block_map(10), {{{0.4, 5}, {9.7, 5}}}, 400, 400);
  ASSERT_TRUE(m.straightness);
  EXPECT_NEAR(*m.straightness, warp::chord_deviation({a, {200, 170}, b}), 1e-9);
  EXPECT_EQ(*m.lines_measured, 1);
  // Only what is on screen: on a 300 px wide screen the line ends at the border (x = 300).
  const auto cut = warp::line_bend(v, {{0.4, 5}, {9.7, 5}}, 300, 400);
  ASSERT_TRUE(cut);
  EXPECT_NEAR(cut->deviation, warp::chord_deviation({a, {200, 170}, {300, 170 + 30 * 0.5}}), 1e-9);
}

TEST(Metrics, ALineShorterThanEightScreenPixelsIsNotMeasured) {
  // On the identity, a 7 px line is not measured and a 9 px one is; × 4, a 3 px source line is
  // 12 screen px long and is measured. Screen pixels decide, and a line off the screen is none.
  const warp::View identity = grid_view(2, 100, [](Point p) { return p; });
  auto m = warp::mesh_view_metrics(identity, identity, block_map(100), {{{20, 30}, {27, 30}}}, 100, 100);
  EXPECT_FALSE(m.straightness);
  EXPECT_EQ(*m.lines_measured, 0);
  m = warp::mesh_view_metrics(identity, identity, block_map(100), {{{20, 30}, {29, 30}}, {{20, 30}, {27, 30}}}, 100, 100);
  EXPECT_NEAR(*m.straightness, 0, 1e-12);
  EXPECT_EQ(*m.lines_measured, 1);
  const warp::View magnified = grid_view(2, 100, [](Point p) { return Point{4 * p.x, 4 * p.y}; });
  m = warp::mesh_view_metrics(magnified, magnified, block_map(100), {{{5, 10}, {8, 10}}, {{90, 90}, {99, 90}}}, 100,
                              100);
  EXPECT_EQ(*m.lines_measured, 1) << "the second line is at x = 360…396, off a 100 px screen";
}

TEST(Metrics, TheRasterisedMapLocatesAsTheScan) {
  // A fold-free random mesh (a 8 × 8 grid over [0, 100]², half its inner vertices jittered, the
  // rest left on lines x, y = 12.5·k through pixel centres, so that many centres lie exactly on
  // edges) under a smooth warp: each map pixel's triangle is locate_in's, and the salient area
  // and anisotropy are those of a scan over every pixel with locate_in.
  std::mt19937 random(30);
  std::uniform_real_distribution<double> jitter(-3, 3);
  warp::View v = grid_view(8, 100, [](Point p) {
    return Point{5 + 2 * p.x + 3 * std::sin(p.y / 15), 5 + 2 * p.y + 3 * std::sin(p.x / 17)};
  });
  for (int i = 0; i < int(v.source.vertices.size()); ++i) {
    Point& p = v.source.vertices[i];
    if (p.x > 0 && p.x < 100 && p.y > 0 && p.y < 100 && random() % 2) p.x += jitter(random), p.y += jitter(random);
  }
  const warp::View identity = grid_view(8, 100, [](Point p) { return p; });
  warp::SignificanceMap map = block_map(100);
  std::uniform_real_distribution<float> value(0, 1);
  for (float& s : map.values) s = value(random);
  const std::vector<int> holder = warp::map_pixel_triangles(v.source, 100, 100, 1);
  double area = 0, aniso = 0, count = 0;
  const auto salient = [&] {  // the top tenth: no ties among random floats
    std::vector<float> sorted = map.values;
    std::nth_element(sorted.begin(), sorted.begin() + 999, sorted.end(), std::greater<>());
    return sorted[999];
  }();
  int on_edges = 0;
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 100; ++x) {
      const Point p{x + 0.5, y + 0.5};
      const warp::MeshPoint where = warp::locate_in(v.source, p);
      ASSERT_EQ(holder[std::size_t(y) * 100 + x], where.triangle) << x << ", " << y;
      on_edges += std::min({where.barycentric[0], where.barycentric[1], where.barycentric[2]}) < 1e-12;
      if (map.values[std::size_t(y) * 100 + x] < salient) continue;
      const warp::Triangle& t = v.source.triangles[where.triangle];
      const Point &a = v.source.vertices[t[0]], &b = v.source.vertices[t[1]], &c = v.source.vertices[t[2]];
      area += std::abs(warp::signed_area2(v.screen[t[0]], v.screen[t[1]], v.screen[t[2]]) / warp::signed_area2(a, b, c));
      aniso += warp::anisotropy(a, b, c, v.screen[t[0]], v.screen[t[1]], v.screen[t[2]]), ++count;
    }
  EXPECT_GT(on_edges, 100) << "the test must probe centres on edges";
  const auto m = warp::mesh_view_metrics(v, identity, map, {}, 215, 215);
  EXPECT_NEAR(*m.scale_gain, area / count, 1e-12 * area / count);
  EXPECT_NEAR(*m.anisotropy_salient, aniso / count, 1e-12);
  // A centre off the mesh has no triangle (it is not drawn), rather than the nearest one's.
  const std::vector<int> wider = warp::map_pixel_triangles(v.source, 120, 120, 1);
  EXPECT_EQ(wider[std::size_t(50) * 120 + 110], -1);
  EXPECT_EQ(wider[std::size_t(50) * 120 + 50], holder[std::size_t(50) * 100 + 50]);
}

TEST(Metrics, PartialCoverageIsItsShare) {
  // The image drawn on the left 60 % of a 100 × 50 screen (letterboxed), and a triangle on half
  // of a 10 × 10 one: pixel centres with x + y ≤ 10 → 55 of 100.
  const warp::View v = grid_view(3, 50, [](Point p) { return Point{1.2 * p.x, p.y}; });
  EXPECT_DOUBLE_EQ(warp::coverage(v, 100, 50), 0.6);
  warp::View half;
  half.source.vertices = {{0, 0}, {10, 0}, {0, 10}};
  half.screen = half.source.vertices;
  half.source.triangles = {{0, 1, 2}};
  half.visible = {0};
  EXPECT_DOUBLE_EQ(warp::coverage(half, 10, 10), 0.55);
  // A rendered screen: the letterbox colour (0) is not covered.
  tiles::Raster screen(10, 4, 3);
  for (int y = 0; y < 3; ++y) std::fill_n(screen.row(y), 30, std::uint8_t(200));
  const auto r = warp::raster_view_metrics(screen, {}, warp::View{}, warp::SignificanceMap{});
  EXPECT_DOUBLE_EQ(r.coverage, 0.75);
  EXPECT_FALSE(r.folds);
  EXPECT_FALSE(r.scale_gain);
}

TEST(Metrics, ARasterMethodsGainCountsTheScreenPixelsShowingTheSalientRegion) {
  // A 10 × 10 image whose left column is the salient tenth; traditional zoom shows it 1:1 on a
  // 10 × 10 screen (10 salient pixels). A method that draws that column two pixels wide (and the
  // other nine columns into the remaining eight) shows it on 20: gain 2.
  warp::SignificanceMap map;
  map.width = map.height = 10, map.scale = 1;
  map.values.assign(100, 0.f);
  for (int y = 0; y < 10; ++y) map.values[std::size_t(y) * 10] = 1.f;
  warp::View traditional;
  traditional.geometry.screen_scale = 1;
  std::vector<Point> sources;
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) sources.push_back({x < 2 ? 0.5 : 1 + (x - 2 + 0.5) * 9 / 8, y + 0.5});
  tiles::Raster screen(10, 10, 3);
  std::fill(screen.pixels.begin(), screen.pixels.end(), std::uint8_t(128));
  const auto r = warp::raster_view_metrics(screen, sources, traditional, map);
  ASSERT_TRUE(r.scale_gain);
  EXPECT_DOUBLE_EQ(*r.scale_gain, 2);
  EXPECT_DOUBLE_EQ(r.coverage, 1);
  EXPECT_FALSE(r.anisotropy_salient);
  // Letterboxed pixels (NaN) show nothing.
  std::fill(sources.begin(), sources.begin() + 10, Point{std::nan(""), std::nan("")});
  std::fill(screen.pixels.begin(), screen.pixels.end(), std::uint8_t(0));  // black content is covered
  const auto letterboxed = warp::raster_view_metrics(screen, sources, traditional, map);
  EXPECT_DOUBLE_EQ(*letterboxed.scale_gain, 1.8);
  EXPECT_DOUBLE_EQ(letterboxed.coverage, 0.9);
}

TEST(Metrics, SimilarityFitResidual) {
  const std::vector<Point> square = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}, {0.3, 0.2}};
  std::vector<Point> similar, stretched, mirrored;
  for (const Point& p : square) {
    similar.push_back({3 * (0.6 * p.x - 0.8 * p.y) + 7, 3 * (0.8 * p.x + 0.6 * p.y) - 2});
    mirrored.push_back({-p.x, p.y});
  }
  EXPECT_NEAR(warp::similarity_fit_residual(square, similar), 0, 1e-9);
  // diag(2, 1) of (±1, 0), (0, ±1): s = 1.5, residual RMS 0.5, RMS radius 1 → 1/3.
  const std::vector<Point> cross = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
  for (const Point& p : cross) stretched.push_back({2 * p.x, p.y});
  EXPECT_NEAR(warp::similarity_fit_residual(cross, stretched), 1.0 / 3, 1e-12);
  EXPECT_GT(warp::similarity_fit_residual(square, mirrored), 0.1) << "a reflection is not a similarity";
  EXPECT_TRUE(std::isnan(warp::similarity_fit_residual({{1, 1}, {1, 1}}, {{0, 0}, {1, 1}})));
}

// ---- On the samples: icaz, traditional and retarget-zoom at z ∈ {0, 0.5, 1}.

struct Sample {
  const char* file;
  bool horizon;  // a curator line across at 62 % of the height (the boats' shore)
};

warp::ImageModel sample_model(const Sample& s) {
  const tiles::Raster full = testing::load_image(testing::samples_dir() + "/" + s.file);
  const double f = std::min(1.0, double(warp::kSignificanceMaxSide) / std::max(full.width, full.height));
  const tiles::Raster small = testing::resize(full, std::max(1, int(full.width * f)), std::max(1, int(full.height * f)));
  std::vector<warp::Segment> lines;
  if (s.horizon) lines.push_back({{0, 0.62 * full.height}, {double(full.width), 0.62 * full.height}});
  return warp::make_image_model(small, full.width, full.height, lines);
}

std::string cell_text(const std::optional<double>& v) {
  if (!v) return "—";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", *v);
  return buf;
}

TEST(MetricsOnSamples, RetargetingMethodsNeverFoldAndCoverTheScreen) {
  std::printf(
      "| image | screen | zoom | method | gain | aniso. salient | aniso. weighted | rot. p95 | rot. spread | line px | "
      "folds | coverage |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Sample& s : {Sample{"boats_lake_sunset.jpg", true}, Sample{"interior_wine_djembe_tall.jpg", false},
                          Sample{"pano_grossmugl_field_4to1.png", false}}) {
    warp::Icaz icaz(sample_model(s));
    const warp::ImageModel& model = icaz.model();
    warp::RetargetZoom retarget_zoom(model, model.significance);
    for (auto [sw, sh] : {std::pair{480, 360}, std::pair{360, 640}})
      for (double z : {0.0, 0.5, 1.0}) {
        warp::ViewRequest r;
        r.zoom = z, r.cx = 0.45 * model.width, r.cy = 0.55 * model.height, r.screen_width = sw, r.screen_height = sh;
        const warp::View traditional = icaz.traditional(r);
        const std::pair<const char*, warp::View> views[] = {
            {"icaz", icaz.view(r)}, {"traditional", traditional}, {"retarget-zoom", retarget_zoom.view(r)}};
        for (const auto& [name, v] : views) {
          SCOPED_TRACE(::testing::Message() << s.file << " " << sw << "×" << sh << " z=" << z << " " << name);
          const auto m = warp::mesh_view_metrics(v, traditional, model.significance, model.lines, sw, sh);
          std::printf("| %s | %d×%d | %.1f | %s | %s | %s | %s | %s | %s | %s | %d | %.4f |\n", s.file, sw, sh, z, name,
                      cell_text(m.scale_gain).c_str(), cell_text(m.anisotropy_salient).c_str(),
                      cell_text(m.anisotropy_weighted).c_str(), cell_text(m.rotation_p95).c_str(),
                      cell_text(m.rotation_spread).c_str(), cell_text(m.straightness).c_str(), *m.folds, m.coverage);
          EXPECT_EQ(*m.folds, 0);
          // The retargeting methods cover the screen — except where zoom 1 shows an image smaller
          // than the screen 1:1, letterboxed by design (zoom_curve.h): then the image's share.
          const warp::ZoomGeometry& g = v.geometry;
          const double shown = std::min(1.0, g.target_width * g.screen_scale / sw) *
                               std::min(1.0, g.target_height * g.screen_scale / sh);
          if (std::string(name) != "traditional") {
            EXPECT_GE(m.coverage, 0.999 * shown);
          }
          ASSERT_TRUE(m.scale_gain && m.anisotropy_salient);
          if (std::string(name) == "traditional") {
            EXPECT_NEAR(*m.scale_gain, 1, 1e-12);
            EXPECT_NEAR(*m.anisotropy_salient, 1, 1e-6) << "traditional zoom is a uniform scale";
          }
        }
      }
  }
}

}  // namespace
}  // namespace zoomwarp
