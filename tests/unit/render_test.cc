// render_view on hand-made views, where the expected pixels follow from the mapping alone.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <algorithm>
#include <string>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "tiles/pyramid_reader.h"
#include "warp/icaz/icaz.h"
#include "warp/render/render.h"

namespace zoomwarp {
namespace {

// A wide strip whose red channel is a smooth ramp along x: the value says where a pixel came from.
constexpr int kWidth = 40000, kHeight = 32;
double ramp(double x) { return 255.0 * x / kWidth; }

tiles::Raster ramp_strip() {
  tiles::Raster r(kWidth, kHeight, 3);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      std::uint8_t* p = r.row(y) + 3 * x;
      p[0] = std::uint8_t(std::lround(ramp(x + 0.5))), p[1] = 128, p[2] = 64;
    }
  return r;
}

// Source rectangle [u0, u0 + w] × [0, kHeight] shown 1:1 at screen x = sx (two triangles).
void add_quad(warp::View& v, double u0, double w, double sx) {
  const int base = int(v.source.vertices.size());
  for (const auto& [du, dv] : {std::pair{0.0, 0.0}, {w, 0.0}, {w, double(kHeight)}, {0.0, double(kHeight)}}) {
    v.source.vertices.push_back({u0 + du, dv});
    v.screen.push_back({sx + du, dv});
  }
  for (const warp::Triangle& t : {warp::Triangle{base, base + 1, base + 2}, warp::Triangle{base, base + 2, base + 3}}) {
    v.visible.push_back(int(v.source.triangles.size()));
    v.source.triangles.push_back(t);
  }
}

// Two pieces of the strip ~39 600 px apart drawn side by side at magnification 1: both are read
// from level 0, and one patch spanning both would be wider than cv::remap's fixed-point positions
// reach (32 767 px). The far piece must still show its own pixels, not those of x ≈ 32 767.
TEST(RenderView, FarApartTrianglesOfOneLevelShowTheirOwnPixels) {
  testing::TempDir dir;
  const std::string file = dir.path() + "/strip.png";
  testing::write_image(file, ramp_strip());
  tiles::Store store(dir.path() + "/store");
  tiles::ingest_image(store, file, "strip", {});
  const auto entry = store.find("strip");
  ASSERT_TRUE(entry);

  warp::View view;
  add_quad(view, 100, 200, 0);
  add_quad(view, 39600, 200, 200);
  tiles::PyramidReader reader(16 << 20);
  const tiles::Raster screen = warp::render_view(view, 400, kHeight, *entry, reader);

  for (int x = 2; x < 398; x += 7) {
    const double source_x = x < 200 ? 100 + x + 0.5 : 39600 + (x - 200) + 0.5;
    SCOPED_TRACE(::testing::Message() << "screen x " << x << ", source x " << source_x);
    EXPECT_NEAR(screen.row(kHeight / 2)[3 * x], ramp(source_x), 2.0);
  }
}

// Traditional zoom is drawn with one affine warp of the whole screen (View::uniform). It must show
// what its triangles show: the same letterbox, the same pixels up to the rounding of sub-pixel
// positions (OpenCV keeps 1/32 px), and exactly the crop at zoom 1.
TEST(RenderView, UniformViewsMatchTheirTriangles) {
  testing::TempDir dir;
  const int w = 1800, h = 700;
  const tiles::Raster pattern = testing::test_pattern(w, h, 3);
  const std::string file = dir.path() + "/pattern.png";
  testing::write_image(file, pattern);
  tiles::Store store(dir.path() + "/store");
  tiles::ingest_image(store, file, "pattern", {});
  const auto entry = store.find("pattern");
  ASSERT_TRUE(entry);
  warp::Icaz icaz(warp::make_image_model(testing::test_pattern(1024, 398, 3), w, h));
  tiles::PyramidReader reader(64 << 20);

  struct Case {
    double zoom, cx, cy;
    int sw, sh;
  };
  for (const Case c : {Case{0, 900, 350, 480, 360}, Case{0.3, 500, 200, 360, 640}, Case{0.55, 1700, 650, 480, 360},
                       Case{0.8, 20, 30, 1000, 200}, Case{1, 901, 349, 480, 360}, Case{0, 900, 350, 64, 700}}) {
    SCOPED_TRACE(::testing::Message() << "zoom " << c.zoom << " screen " << c.sw << "×" << c.sh);
    warp::ViewRequest r;
    r.zoom = c.zoom, r.cx = c.cx, r.cy = c.cy, r.screen_width = c.sw, r.screen_height = c.sh;
    warp::View view = icaz.traditional(r);
    ASSERT_TRUE(view.uniform);
    const tiles::Raster affine = warp::render_view(view, c.sw, c.sh, *entry, reader);
    view.uniform = false;
    const tiles::Raster triangles = warp::render_view(view, c.sw, c.sh, *entry, reader);
    int differing = 0, largest = 0, blank_mismatch = 0;
    for (int y = 0; y < c.sh; ++y)
      for (int x = 0; x < c.sw; ++x) {
        const std::uint8_t *a = affine.row(y) + 3 * x, *t = triangles.row(y) + 3 * x;
        int d = 0;
        for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(int(a[k]) - int(t[k])));
        differing += d > 0, largest = std::max(largest, d);
        blank_mismatch += (a[0] == 0 && a[1] == 0 && a[2] == 0) != (t[0] == 0 && t[1] == 0 && t[2] == 0) && d > 10;
      }
    EXPECT_EQ(blank_mismatch, 0);
    // A position rounded to 1/32 px moves a sample on a full-contrast edge by ≤ 255/32 ≈ 8 levels,
    // plus a level of rounding on each side.
    EXPECT_LE(largest, 10);
    EXPECT_LE(differing, c.sw * c.sh / 20);
    if (c.zoom == 1) {
      EXPECT_EQ(differing, 0);
      const tiles::Raster crop = testing::crop(pattern, {long(std::lround(view.view_x)), long(std::lround(view.view_y)), c.sw, c.sh});
      EXPECT_EQ(affine.pixels, crop.pixels);
    }
  }
}

}  // namespace
}  // namespace zoomwarp
