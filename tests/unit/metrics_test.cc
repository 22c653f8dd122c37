// The comparison metrics (warp/compare/metrics.h) on synthetic meshes with known answers, and
// then on the samples for icaz, traditional and retarget-zoom: no fold-overs and a covered screen
// for the retargeting methods, with the table printed.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
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
  std::printf("| image | screen | zoom | method | gain | aniso. salient | aniso. weighted | line px | folds | coverage |\n"
              "|---|---|---|---|---|---|---|---|---|---|\n");
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
          std::printf("| %s | %d×%d | %.1f | %s | %s | %s | %s | %s | %d | %.4f |\n", s.file, sw, sh, z, name,
                      cell_text(m.scale_gain).c_str(), cell_text(m.anisotropy_salient).c_str(),
                      cell_text(m.anisotropy_weighted).c_str(), cell_text(m.straightness).c_str(), *m.folds, m.coverage);
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
