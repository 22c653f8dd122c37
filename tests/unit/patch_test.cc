// method=patch (warp/methods/patch/): the energy of [Lin13] on the samples' grids, as issue 14's
// acceptance asks — the two precomputed solves combine into exactly the direct solve of any
// target (to 1e-6 px), the identity at the image's own size and exact scaling, the boundary on
// the target, no fold-over at 9:16, 1:1, 16:9 and 3:1 after the Retargeter's guard; each term
// doing its job (without D_OR horizontal grid lines bend, without D_ST significant patches lose
// their shape, without the line term a line bends); the model's bytes round trip. And issue 30's
// acceptance: on phone screens at zoom 0 every curator and detected line stays within 2 px of
// straight and the salient rotation p95 within 10°.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <stdexcept>

#include "tests/support/analysed_image.h"
#include "warp/compare/metrics.h"
#include "warp/methods/method_lines.h"
#include "warp/core/fold_blend.h"
#include "warp/core/uniform_zoom.h"
#include "warp/methods/patch/patch_precompute.h"
#include "warp/methods/patch/patch_retargeter.h"
#include "warp/methods/patch/patch_segmentation.h"
#include "warp/saliency/significance.h"

namespace zoomwarp {
namespace {

using warp::Point;

// The samples' models (default saliency unless asked), built once per process.
struct Built {
  testing::AnalysedImage image;
  warp::Saliency kind;
  warp::SignificanceMap map;
  warp::PatchModel model;
  std::vector<warp::Segment> lines;  // analysis px
};
const Built& built(const std::string& file, warp::Saliency kind = warp::Saliency::kDefault) {
  static std::map<std::pair<std::string, warp::Saliency>, Built> cache;
  const auto key = std::make_pair(file, kind);
  auto it = cache.find(key);
  if (it == cache.end()) {
    Built b{testing::analyse_sample(file), kind, {}, {}, {}};
    b.map = b.image.saliency(kind);
    const warp::MethodInput in = b.image.input(kind, b.map);
    b.model = warp::build_patch_model(in);
    b.lines = warp::method_lines(in);
    it = cache.emplace(key, std::move(b)).first;
  }
  return it->second;
}

const char* const kSamples[] = {"boats_lake_sunset.jpg", "astronaut_portrait.png", "interior_wine_djembe_tall.jpg",
                                "pano_grossmugl_field_4to1.png"};

// Equal-area targets (analysis px) at the screen aspects.
std::vector<std::pair<double, double>> targets(const warp::PatchGrid& g) {
  std::vector<std::pair<double, double>> t;
  for (double a : {9.0 / 16, 1.0, 16.0 / 9, 3.0}) t.emplace_back(std::sqrt(g.width * g.height * a), std::sqrt(g.width * g.height / a));
  return t;
}

double max_distance(const std::vector<Point>& a, const std::vector<Point>& b) {
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::hypot(a[i].x - b[i].x, a[i].y - b[i].y));
  return d;
}

TEST(PatchEnergy, TheTwoSolvesCombineIntoTheDirectSolve) {
  for (const char* file : kSamples) {
    const Built& b = built(file);
    for (auto [tw, th] : targets(b.model.grid)) {
      const std::vector<Point> direct = warp::solve_patch_direct(b.model.grid, b.lines, tw, th);
      const double d = max_distance(warp::patch_positions(b.model, tw, th), direct);
      EXPECT_LT(d, 1e-6) << file << " " << tw << " x " << th;
    }
  }
}

TEST(PatchEnergy, IdentityAtTheImagesOwnSizeAndExactScaling) {
  for (const char* file : kSamples) {
    const Built& b = built(file);
    const warp::Mesh source = warp::patch_mesh(b.model.grid);
    const double w = b.model.grid.width, h = b.model.grid.height;
    EXPECT_LT(max_distance(warp::patch_positions(b.model, w, h), source.vertices), 1e-6) << file;
    std::vector<Point> scaled = warp::patch_positions(b.model, 0.5 * w, 0.5 * h);
    for (Point& p : scaled) p = {2 * p.x, 2 * p.y};
    EXPECT_LT(max_distance(scaled, source.vertices), 1e-6) << file;
  }
}

TEST(PatchEnergy, BoundaryExactlyOnTheTarget) {
  const Built& b = built("boats_lake_sunset.jpg");
  const warp::PatchGrid& g = b.model.grid;
  for (auto [tw, th] : targets(g)) {
    const std::vector<Point> q = warp::patch_positions(b.model, tw, th);
    for (int j = 0; j <= g.ny; ++j) {
      EXPECT_NEAR(q[g.vertex(0, j)].x, 0, 1e-9);
      EXPECT_NEAR(q[g.vertex(g.nx, j)].x, tw, 1e-9);
    }
    for (int i = 0; i <= g.nx; ++i) {
      EXPECT_NEAR(q[g.vertex(i, 0)].y, 0, 1e-9);
      EXPECT_NEAR(q[g.vertex(i, g.ny)].y, th, 1e-9);
    }
  }
}

// After the Retargeter's guard nothing folds; how often the guard had to blend is reported.
TEST(PatchRetargeting, NoFoldOverAtFourAspectsWithBothSaliencies) {
  int blended = 0, total = 0;
  for (const char* file : kSamples)
    for (warp::Saliency kind : warp::kSaliencies) {
      const Built& b = built(file, kind);
      const warp::PatchRetargeting r(b.image.model.width, b.image.model.height, b.model);
      for (double a : {9.0 / 16, 1.0, 16.0 / 9, 3.0}) {
        const double tw = std::sqrt(b.image.model.width * b.image.model.height * a);
        const double th = b.image.model.width * b.image.model.height / tw;
        double t = 0;
        const std::vector<Point> q = r.warped(tw, th, &t);
        EXPECT_TRUE(warp::folded_triangles(r.mesh(), q).empty()) << file << " " << a;
        // The guard blends only where the energy's minimiser itself folds.
        const std::vector<Point> raw = warp::patch_positions(b.model, tw * b.model.grid.width / b.image.model.width,
                                                             th * b.model.grid.height / b.image.model.height);
        EXPECT_EQ(t > 0, !warp::folded_triangles(warp::patch_mesh(b.model.grid), raw).empty()) << file << " " << a;
        blended += t > 0;
        ++total;
        if (t > 0) std::printf("[ guard    ] %s %s aspect %.2f: blended %.4f toward the stretch\n", file,
                               std::string(warp::saliency_name(kind)).c_str(), a, t);
      }
    }
  std::printf("[ guard    ] %d of %d targets needed the blend\n", blended, total);
  EXPECT_GT(blended, 0) << "the 4:1 panorama on a 9:16 screen folds: the guard must have been exercised";
}

// D_OR keeps the grid's horizontal lines horizontal [Lin13 eq. 5]: without it, the mean
// |y'_a − y'_b| over horizontal grid edges grows.
TEST(PatchEnergy, WithoutTheOrientationTermHorizontalGridLinesBend) {
  const Built& b = built("boats_lake_sunset.jpg");
  const warp::PatchGrid& g = b.model.grid;
  const auto tilt = [&](const std::vector<Point>& q) {
    double sum = 0;
    for (int j = 0; j <= g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) sum += std::abs(q[g.vertex(i, j)].y - q[g.vertex(i + 1, j)].y);
    return sum / ((g.ny + 1) * g.nx);
  };
  warp::PatchEnergyOptions without;
  without.orientation_weight = 0;
  for (auto [tw, th] : targets(g)) {
    if (std::abs(tw - g.width) < 1) continue;
    const double with_or = tilt(warp::solve_patch_direct(g, b.lines, tw, th));
    const double without_or = tilt(warp::solve_patch_direct(g, b.lines, tw, th, without));
    std::printf("[ D_OR     ] %.0f x %.0f: mean |dy| of horizontal edges %.4f px with D_OR, %.4f without\n", tw, th,
                with_or, without_or);
    EXPECT_GT(without_or, 1.5 * with_or);
  }
}

// D_ST keeps significant patches similar [Lin13 eq. 2]. The boats with their row of boats marked
// important by a curator (weight 1): over the patches with s_i ≥ 0.8 spanning ≥ 4 quads, the
// similarity-fit residual of their quads' corners is below the uniform stretch's at 9:16 (an
// aspect change ≥ 1.5), and grows without D_ST.
TEST(PatchEnergy, WithoutTheSimilarityTermSignificantPatchesLoseTheirShape) {
  const Built& b = built("boats_lake_sunset.jpg");
  warp::SignificanceMap marked = b.map;
  warp::paint_polygon(marked, {{0, 1000}, {1800, 1000}, {1800, 1450}, {0, 1450}}, 1);
  const warp::PatchGrid g = warp::make_patch_grid(warp::segment_patches(b.image.analysis), marked,
                                                  double(b.image.analysis.width) / b.image.model.width);
  std::map<int, std::vector<int>> corners;  // significant patch → its quads' corner vertices
  std::map<int, int> quads;
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const int p = g.quad_patch[j * g.nx + i];
      if (g.significance[p] < 0.8) continue;
      ++quads[p];
      for (int v : {g.vertex(i, j), g.vertex(i + 1, j), g.vertex(i, j + 1), g.vertex(i + 1, j + 1)}) corners[p].push_back(v);
    }
  const warp::Mesh source = warp::patch_mesh(g);
  const auto residual = [&](const std::vector<Point>& q) {
    double sum = 0;
    int n = 0;
    for (const auto& [p, vs] : corners) {
      if (quads[p] < 4) continue;
      std::vector<Point> from, to;
      for (int v : vs) from.push_back(source.vertices[v]), to.push_back(q[v]);
      sum += warp::similarity_fit_residual(from, to);
      ++n;
    }
    EXPECT_GT(n, 0) << "no significant patch spans 4 quads";
    return n ? sum / n : 0;
  };
  warp::PatchEnergyOptions without;
  without.similarity_weight = 0;
  const double tw = std::sqrt(g.width * g.height * 9 / 16), th = g.width * g.height / tw;
  std::vector<Point> stretch = source.vertices;
  for (Point& p : stretch) p = {p.x * tw / g.width, p.y * th / g.height};
  const double with_st = residual(warp::solve_patch_direct(g, b.lines, tw, th));
  const double without_st = residual(warp::solve_patch_direct(g, b.lines, tw, th, without));
  const double uniform = residual(stretch);
  std::printf("[ D_ST     ] boats, boats marked, 9:16: mean similarity residual of significant patches %.4f with D_ST, "
              "%.4f without, %.4f under the uniform stretch (ratio %.2f)\n",
              with_st, without_st, uniform, with_st / uniform);
  EXPECT_LT(with_st, 0.5 * uniform);
  EXPECT_GT(without_st, 1.5 * with_st);
}

// A line (the curator's, in analysis px) stays straight: its points, carried by the triangles the
// client draws, lie within 1 px of its warped chord; without the line term it bends.
TEST(PatchEnergy, ALineStaysStraightWithItsTermAndBendsWithout) {
  const Built& b = built("boats_lake_sunset.jpg");
  const warp::PatchGrid& g = b.model.grid;
  const warp::Mesh mesh = warp::patch_mesh(g);
  const warp::Segment line{{0.1 * g.width, 0.55 * g.height}, {0.9 * g.width, 0.75 * g.height}};
  const auto bend = [&](const std::vector<Point>& q) {
    std::vector<Point> samples;
    for (int k = 0; k <= 1000; ++k) {
      const double t = k / 1000.0;
      samples.push_back(warp::locate(mesh, q, {line.a.x + t * (line.b.x - line.a.x), line.a.y + t * (line.b.y - line.a.y)}));
    }
    return warp::chord_deviation(samples);
  };
  warp::PatchEnergyOptions without;
  without.line_weight = 0;
  const double tw = std::sqrt(g.width * g.height * 9 / 16), th = g.width * g.height / tw;
  const double kept = bend(warp::solve_patch_direct(g, {line}, tw, th));
  const double bent = bend(warp::solve_patch_direct(g, {line}, tw, th, without));
  std::printf("[ line     ] 9:16: %.3f px from straight with the line term, %.3f px without\n", kept, bent);
  EXPECT_LT(kept, 1);
  EXPECT_GT(bent, 1);
}

// Issue 30: no method bends what should stay straight. On a phone both ways up, at zoom 0,
// centred, the model as the server loads it (stored, parsed): every curator and detected line
// whose chord on screen is at least warp::kMinMeasuredLinePx long lies within kMaxBendPx of that
// chord, measured as the client draws the grid (two triangles per quad: warp/compare/metrics.h
// line_bend, exact at the triangle edges), and the warp does not buy that by turning content: the
// salient rotation p95 is at most kMaxRotationDeg. The samples have no curator lines; the 4:1
// panorama is tried again with one drawn obliquely across its field, which the 9:16 screen turns
// steep (held only every quad side's length, it bent 3.1 px there). Gain over traditional zoom is
// reported.
TEST(PatchRetargeting, LinesStayStraightOnPhoneScreens) {
  constexpr double kMaxBendPx = 2, kMaxRotationDeg = 10;
  const auto check = [&](const std::string& name, const testing::AnalysedImage& image, warp::Saliency kind) {
    const warp::SignificanceMap map = image.saliency(kind);
    const double w = image.model.width, h = image.model.height;
    warp::PatchRetargeting r(w, h, warp::parse_patch_model(warp::patch_model_bytes(warp::build_patch_model(image.input(kind, map)))));
    std::vector<warp::Segment> lines = image.model.lines;
    lines.insert(lines.end(), image.detected.begin(), image.detected.end());
    for (const auto& [sw, sh] : {std::pair{360, 640}, std::pair{640, 360}}) {
      warp::ViewRequest request;
      request.cx = w / 2, request.cy = h / 2, request.screen_width = sw, request.screen_height = sh;
      const warp::View v = r.view(request);
      const warp::View traditional = warp::uniform_zoom_of_warp(r.mesh(), r.mesh().vertices, w, h, request, w, h);
      const warp::ViewMetrics m = warp::mesh_view_metrics(v, traditional, map, lines, sw, sh);
      const std::string label = name + " " + std::string(warp::saliency_name(kind)) + " " + std::to_string(sw) + "x" +
                                std::to_string(sh);
      ASSERT_TRUE(m.rotation_p95 && m.scale_gain) << label;
      EXPECT_LE(m.straightness.value_or(0), kMaxBendPx) << label;
      EXPECT_LE(*m.rotation_p95, kMaxRotationDeg) << label;
      std::printf("[ lines    ] %-48s %2d lines, worst bend %.2f px, rotation p95 %.1f°, gain %.2f\n", label.c_str(),
                  m.lines_measured.value_or(0), m.straightness.value_or(0), *m.rotation_p95, *m.scale_gain);
    }
  };
  for (const char* file : kSamples)
    for (warp::Saliency kind : warp::kSaliencies) check(file, built(file, kind).image, kind);
  testing::AnalysedImage furrow = built("pano_grossmugl_field_4to1.png").image;
  const double w = furrow.model.width, h = furrow.model.height;
  furrow.model.lines = {{{0.05 * w, 0.1 * h}, {0.95 * w, 0.7 * h}}};
  for (warp::Saliency kind : warp::kSaliencies) check("pano_grossmugl_field_4to1.png + curator line", furrow, kind);
}

TEST(PatchModelBytes, RoundTripAndRefusal) {
  const Built& b = built("astronaut_portrait.png");
  const std::string bytes = warp::patch_model_bytes(b.model);
  const warp::PatchModel back = warp::parse_patch_model(bytes);
  EXPECT_EQ(warp::patch_model_bytes(back), bytes);
  EXPECT_THROW(warp::parse_patch_model(bytes.substr(0, bytes.size() - 1)), std::runtime_error);
  EXPECT_THROW(warp::parse_patch_model(bytes + "x"), std::runtime_error);
  EXPECT_THROW(warp::parse_patch_model(""), std::runtime_error);
  std::string huge = bytes;
  const std::int32_t big = 1 << 30;
  std::memcpy(huge.data() + 16, &big, 4);  // nx
  EXPECT_THROW(warp::parse_patch_model(huge), std::runtime_error);
}

// Precompute time at analysis size (reported, not asserted).
TEST(PatchPrecompute, Samples) {
  for (const char* file : kSamples) {
    const testing::AnalysedImage image = testing::analyse_sample(file);
    const warp::SignificanceMap map = image.saliency(warp::Saliency::kDefault);
    const auto t0 = std::chrono::steady_clock::now();
    const warp::PatchModel m = warp::build_patch_model(image.input(warp::Saliency::kDefault, map));
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::printf("[ patch    ] %-32s %4dx%-4d grid %dx%d, %zu patches, %.0f ms\n", file, image.analysis.width,
                image.analysis.height, m.grid.nx, m.grid.ny, m.grid.significance.size(), ms);
    EXPECT_EQ(m.per_width.size(), std::size_t(m.grid.nx + 1) * (m.grid.ny + 1));
  }
}

}  // namespace
}  // namespace zoomwarp
