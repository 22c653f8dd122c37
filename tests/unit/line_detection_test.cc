// Automatic line detection (warp/lines/line_detection.h): straight edges of synthetic images are
// found where they are, noise and flat images give none, the curator's limits hold, degenerate
// images give none, and the suggestions left for the curator drop dismissed and curated lines.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <numbers>
#include <random>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/analysis/detected_lines.h"
#include "warp/core/limits.h"
#include "warp/lines/line_detection.h"
#include "warp/meshing/coarse_mesh.h"

namespace zoomwarp {
namespace {

using warp::Point;
using warp::Segment;

double length(const Segment& s) { return std::hypot(s.b.x - s.a.x, s.b.y - s.a.y); }

// Angle between the two segments' directions, in degrees, in [0, 90].
double angle_between(const Segment& s, const Segment& t) {
  const double c = std::abs((s.b.x - s.a.x) * (t.b.x - t.a.x) + (s.b.y - s.a.y) * (t.b.y - t.a.y)) / (length(s) * length(t));
  return std::acos(std::min(1.0, c)) * 180 / std::numbers::pi;
}

// Distance of p from the infinite line through t.
double distance_to_line(const Point& p, const Segment& t) {
  return std::abs((p.x - t.a.x) * (t.b.y - t.a.y) - (p.y - t.a.y) * (t.b.x - t.a.x)) / length(t);
}

// s lies on the truth t: within 1° of its direction, both ends within 2 px of its line, and it
// covers at least `coverage` of t's length.
bool on_truth(const Segment& s, const Segment& t, double coverage) {
  return angle_between(s, t) <= 1 && distance_to_line(s.a, t) <= 2 && distance_to_line(s.b, t) <= 2 &&
         length(s) >= coverage * length(t);
}

std::string describe(const std::vector<Segment>& segments) {
  std::string out;
  for (const Segment& s : segments)
    out += "(" + std::to_string(s.a.x) + ", " + std::to_string(s.a.y) + ") – (" + std::to_string(s.b.x) + ", " +
           std::to_string(s.b.y) + ") ";
  return out;
}

tiles::Raster flat(int w, int h, std::uint8_t value) {
  tiles::Raster r(w, h, 3);
  std::fill(r.pixels.begin(), r.pixels.end(), value);
  return r;
}

void fill_rect(tiles::Raster& r, int x0, int y0, int x1, int y1, std::uint8_t value) {
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x)
      for (int c = 0; c < r.channels; ++c) r.row(y)[x * r.channels + c] = value;
}

TEST(LineDetection, FindsTheEdgesOfARectangle) {
  tiles::Raster img = flat(400, 300, 60);
  fill_rect(img, 100, 80, 300, 220, 200);
  const std::vector<Segment> truth = {
      {{100, 80}, {300, 80}}, {{300, 80}, {300, 220}}, {{300, 220}, {100, 220}}, {{100, 220}, {100, 80}}};
  const auto found = warp::detect_lines(img, 400, 300);
  for (const Segment& t : truth)
    EXPECT_TRUE(std::any_of(found.begin(), found.end(), [&](const Segment& s) { return on_truth(s, t, 0.9); }))
        << "edge (" << t.a.x << ", " << t.a.y << ") – (" << t.b.x << ", " << t.b.y << ") not found";
  for (const Segment& s : found)
    EXPECT_TRUE(std::any_of(truth.begin(), truth.end(), [&](const Segment& t) { return on_truth(s, t, 0); }))
        << "spurious segment (" << s.a.x << ", " << s.a.y << ") – (" << s.b.x << ", " << s.b.y << ")";
  EXPECT_EQ(found.size(), 4u) << "one segment per edge: its duplicates and pieces are merged; " << describe(found);
}

TEST(LineDetection, FindsATiltedHorizonInImagePixels) {
  // Sky above y = 200 + 0.1·(x − 320) (5.7°), ground below; the analysis image is a quarter of
  // the image's width and height, so segments come back ×4.
  tiles::Raster img = flat(640, 400, 70);
  for (int y = 0; y < 400; ++y)
    for (int x = 0; x < 640; ++x)
      if (y + 0.5 < 200 + 0.1 * (x + 0.5 - 320)) fill_rect(img, x, y, x + 1, y + 1, 190);
  const Segment truth{{0, 4 * 168.0}, {4 * 640.0, 4 * 232.0}};
  const auto found = warp::detect_lines(img, 2560, 1600);
  ASSERT_EQ(found.size(), 1u) << describe(found);
  const Segment& s = found[0];
  EXPECT_LE(angle_between(s, truth), 1);
  EXPECT_LE(distance_to_line(s.a, truth), 4 * 2.0);  // 2 analysis px
  EXPECT_LE(distance_to_line(s.b, truth), 4 * 2.0);
  EXPECT_GE(length(s), 0.9 * length(truth));
}

TEST(LineDetection, FlatAndNoiseImagesHaveNoLines) {
  EXPECT_TRUE(warp::detect_lines(flat(512, 384, 128), 512, 384).empty());
  tiles::Raster noise(512, 384, 3);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  for (auto& p : noise.pixels) p = std::uint8_t(byte(rng));
  const auto found = warp::detect_lines(noise, 512, 384);
  EXPECT_TRUE(found.empty()) << found.size() << " segments in noise, the longest " << length(found[0]) << " px";
}

TEST(LineDetection, DegenerateImagesHaveNoLines) {
  EXPECT_TRUE(warp::detect_lines(tiles::Raster(), 1, 1).empty());
  tiles::Raster one = flat(1, 1, 255);
  EXPECT_TRUE(warp::detect_lines(one, 1, 1).empty());
  // A 2×10000 image's analysis copy is 1 px wide.
  tiles::Raster sliver = flat(1, 1024, 0);
  fill_rect(sliver, 0, 500, 1, 1024, 255);
  EXPECT_TRUE(warp::detect_lines(sliver, 2, 10000).empty());
  tiles::Raster short_rows = flat(1024, 20, 0);
  fill_rect(short_rows, 0, 10, 1024, 20, 255);
  EXPECT_TRUE(warp::detect_lines(short_rows, 10000, 195).empty());
  // Pixels that do not fill the raster's size are refused, not read past.
  tiles::Raster truncated = flat(64, 64, 0);
  truncated.pixels.resize(100);
  EXPECT_TRUE(warp::detect_lines(truncated, 64, 64).empty());
}

TEST(LineDetection, KeepsTheLongestWithinTheCuratorsLimits) {
  // 31 rows × 6 columns of bars, each a separate line (their gaps exceed d/2 = 29.6 px): 186
  // lines of ~120 px, 22 000 px in all, more than either limit allows.
  tiles::Raster img = flat(1024, 1024, 30);
  for (int row = 1; row < 32; ++row)
    for (int col = 0; col < 6; ++col)
      fill_rect(img, 20 + 160 * col + row % 5, 32 * row, 140 + 160 * col + row % 5, 32 * row + 12, 220);
  const auto found = warp::detect_lines(img, 1024, 1024);
  EXPECT_EQ(found.size(), std::size_t(warp::limits::kMaxLines));
  double total = 0;
  for (std::size_t i = 0; i < found.size(); ++i) {
    total += length(found[i]);
    if (i > 0) {
      EXPECT_GE(length(found[i - 1]), length(found[i]) - 1e-9) << "longest first";
    }
  }
  EXPECT_LE(total, warp::limits::kMaxTotalLineLength * 1024);
}

TEST(LineDetection, LineRichSampleStaysWithinTheLimits) {
  const tiles::Raster full = testing::load_image(testing::samples_dir() + "/interior_wine_djembe_tall.jpg");
  const tiles::Raster analysis = testing::resize(full, 683, 1024);
  const auto start = std::chrono::steady_clock::now();
  const auto found = warp::detect_lines(analysis, full.width, full.height);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  double total = 0;
  for (const Segment& s : found) {
    total += length(s);
    for (const Point& p : {s.a, s.b}) {
      EXPECT_TRUE(p.x >= 0 && p.x <= full.width && p.y >= 0 && p.y <= full.height);
    }
    EXPECT_GE(length(s), 0.1 * 683 * (full.width / 683.0) - 1) << "shorter than 0.1·min(Wa, Ha)";
  }
  std::printf("interior sample: %zu lines, total length %.0f px (limit %.0f), detected in %.1f ms\n", found.size(),
              total, warp::limits::kMaxTotalLineLength * full.height, ms);
  EXPECT_GE(found.size(), 5u) << "a room has straight edges";
  EXPECT_LE(found.size(), std::size_t(warp::limits::kMaxLines));
  EXPECT_LE(total, warp::limits::kMaxTotalLineLength * full.height);
}

TEST(LineDetection, SuggestionsLeaveOutDismissedAndCuratedLines) {
  const std::vector<Segment> detected = {{{10, 10}, {500, 10}}, {{10, 300}, {500, 320}}, {{600, 50}, {600, 700}}};
  // The first dismissed (sent back reversed), the third drawn by the curator a few px off.
  const std::vector<Segment> dismissed = {{{500, 10.4}, {10, 10}}};
  const std::vector<Segment> curator = {{{603, 40}, {604, 650}}};
  const auto left = warp::remaining_suggestions(detected, curator, dismissed, 1000, 800);
  ASSERT_EQ(left.size(), 1u);
  EXPECT_TRUE(warp::same_segment(left[0], detected[1], 0));
  // Nothing dismissed or curated: everything stays, in order.
  EXPECT_EQ(warp::remaining_suggestions(detected, {}, {}, 1000, 800).size(), 3u);
  // A dismissed segment 3 px away names another segment, not this one.
  EXPECT_EQ(warp::remaining_suggestions(detected, {}, {{{10, 13}, {500, 13}}}, 1000, 800).size(), 3u);
}

double distance_to_segment(const Point& p, const Segment& t) {
  const double dx = t.b.x - t.a.x, dy = t.b.y - t.a.y;
  const double u = std::clamp(((p.x - t.a.x) * dx + (p.y - t.a.y) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
  return std::hypot(p.x - t.a.x - u * dx, p.y - t.a.y - u * dy);
}

// The smallest distance from s's points (sampled every 0.5 px) to t.
double clearance(const Segment& s, const Segment& t) {
  double best = INFINITY;
  const int n = int(2 * length(s)) + 1;
  for (int i = 0; i <= n; ++i) {
    const double u = double(i) / n;
    best = std::min(best, distance_to_segment({s.a.x + u * (s.b.x - s.a.x), s.a.y + u * (s.b.y - s.a.y)}, t));
  }
  return best;
}

TEST(ClearPieces, CutsASegmentBackFromTheLinesItCrossesOrTouches) {
  const Segment s{{0, 100}, {1000, 100}};
  // Crossed at x = 300, touched at its end by a vertical line at x = 1000.
  const std::vector<Segment> others = {{{300, 0}, {300, 400}}, {{1000, 100}, {1000, 400}}, {{500, 300}, {700, 300}}};
  const auto pieces = warp::clear_pieces(s, others, 20, 50);
  ASSERT_EQ(pieces.size(), 2u) << describe(pieces);
  EXPECT_NEAR(pieces[0].a.x, 0, 1e-9);
  EXPECT_NEAR(pieces[0].b.x, 280, 1);
  EXPECT_NEAR(pieces[1].a.x, 320, 1);
  EXPECT_NEAR(pieces[1].b.x, 980, 1);
  for (const Segment& p : pieces) {
    EXPECT_EQ(p.a.y, 100);
    EXPECT_EQ(p.b.y, 100);
    for (const Segment& o : others) EXPECT_GE(clearance(p, o), 20 - 1e-9);
  }
  // Too short once cut: nothing left.
  EXPECT_TRUE(warp::clear_pieces({{280, 50}, {320, 50}}, others, 20, 50).empty());
  EXPECT_EQ(warp::clear_pieces(s, {}, 20, 50).size(), 1u);
}

// lines=auto's line set: the curator's lines first, then suggestions within the limits.
TEST(AutoLineSet, AddsSuggestionsWithinTheCuratorsLimits) {
  warp::ImageModel model;
  model.width = 2000, model.height = 1000;
  for (int i = 0; i < 60; ++i) model.lines.push_back({{100, 10.0 + 15 * i}, {300, 10.0 + 15 * i}});
  std::vector<Segment> suggestions;
  for (int i = 0; i < 10; ++i) suggestions.push_back({{1000, 10.0 + 90 * i}, {1900, 10.0 + 90 * i}});
  int dropped = -1;
  const auto lines = warp::auto_line_set(model, suggestions, &dropped);
  ASSERT_EQ(lines.size(), std::size_t(warp::limits::kMaxLines)) << "4 suggestions fit beside 60 curator lines";
  EXPECT_EQ(dropped, 0);
  for (int i = 0; i < 60; ++i) EXPECT_TRUE(warp::same_segment(lines[i], model.lines[i], 0));
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(warp::same_segment(lines[60 + i], suggestions[i], 1e-9));
  // The total length: 10 curator lines of 200 px, then suggestions of 1000 px, at most 16 × 2000 px.
  model.lines.resize(10);
  suggestions.clear();
  for (int i = 0; i < 40; ++i) suggestions.push_back({{400.0 + 40 * i, 0}, {400.0 + 40 * i, 1000}});
  EXPECT_EQ(warp::auto_line_set(model, suggestions).size(), 10u + 30u);
}

// 64 lines crossing on a grid, which CGAL's refinement cannot mesh (CoarseMeshLines test), and
// the same grid 1 % shorter, where adding the third line makes the refinement run without end:
// the suggestions are cut back from every line they cross or touch, and the set meshes.
TEST(AutoLineSet, CutsSuggestionsBackSoThatCGALMeshesThem) {
  for (const double scale : {1.0, 0.99}) {
    warp::ImageModel model;
    model.width = 5400, model.height = 2500;
    const double len = scale * 16.0 / 64 * std::max(model.width, model.height);
    std::vector<Segment> grid;
    for (int i = 0; i < 64; ++i) {
      const double cx = model.width * (0.1 + 0.8 * (i % 8) / 7), cy = model.height * (0.1 + 0.8 * (i / 8) / 7);
      const double angle = (i % 3 == 0 ? 0 : i % 3 == 1 ? 90 : 30) * std::numbers::pi / 180;
      const double dx = std::cos(angle) * len / 2, dy = std::sin(angle) * len / 2;
      grid.push_back({{cx - dx, cy - dy}, {cx + dx, cy + dy}});
    }
    if (scale == 1.0) {
      ASSERT_THROW(warp::build_coarse_mesh(model.width, model.height, grid), std::invalid_argument);
    }
    const std::vector<Segment> suggestions(grid.begin(), grid.end());
    int dropped = -1;
    const auto lines = warp::auto_line_set(model, suggestions, &dropped);
    std::printf("grid ×%.2f: %zu lines from 64 crossing suggestions, %d left out for CGAL\n", scale, lines.size(), dropped);
    EXPECT_EQ(dropped, 0);
    EXPECT_GE(lines.size(), 32u);
    const double d = std::sqrt(model.width * model.height / 300);
    for (std::size_t i = 0; i < lines.size(); ++i) {
      EXPECT_TRUE(std::any_of(grid.begin(), grid.end(), [&](const Segment& g) {
        return distance_to_segment(lines[i].a, g) < 1e-6 && distance_to_segment(lines[i].b, g) < 1e-6;
      })) << "line " << i << " is a piece of a suggestion";
      for (std::size_t j = 0; j < i; ++j) EXPECT_GE(clearance(lines[i], lines[j]), d / 4 - 1e-6) << i << ", " << j;
    }
    EXPECT_NO_THROW(warp::build_coarse_mesh(model.width, model.height, lines));
  }
}

}  // namespace
}  // namespace zoomwarp
