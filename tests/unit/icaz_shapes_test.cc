// Every image shape gets a drawable view: 1×1 up to 10000×2, from every method, at zoom 0, 0.5
// and 1, on portrait, landscape and square screens — no crash, no fold-over, the screen covered
// or letterboxed, zoom 1 the 1:1 crop (letterboxed on images smaller than the screen, with exact
// pixels when rendered). Random sizes and screens (seeded) likewise. Tiny images used to crash
// the process inside CHOLMOD (an empty system: their coarsest mesh has no interior vertex).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "tiles/pyramid_reader.h"
#include "warp/icaz/icaz.h"
#include "warp/methods/retarget_zoom/retarget_zoom.h"
#include "warp/render/render.h"

namespace zoomwarp {
namespace {

using warp::Point;

struct Size {
  int w, h;
};

// The model of a w × h image, built from its ≤ 1024 px reduction as ingest does.
warp::ImageModel model_of(int w, int h) {
  const double f = std::min(1.0, double(warp::kSignificanceMaxSide) / std::max(w, h));
  const int rw = std::max(1, int(std::lround(w * f))), rh = std::max(1, int(std::lround(h * f)));
  return warp::make_image_model(testing::test_pattern(rw, rh, 3), w, h);
}

enum class Method { kIcaz, kTraditional, kRetargetZoom };

// The methods of one image: ICAZ and its traditional baseline, and Retargeting+Zooming (its
// uniform mesh built on first use).
struct Engines {
  explicit Engines(warp::ImageModel model) : icaz(std::move(model)) {}

  warp::View view(Method method, const warp::ViewRequest& r) {
    switch (method) {
      case Method::kIcaz: return icaz.view(r);
      case Method::kTraditional: return icaz.traditional(r);
      case Method::kRetargetZoom:
        if (!retarget_zoom) retarget_zoom = std::make_unique<warp::RetargetZoom>(icaz.model(), icaz.model().significance);
        return retarget_zoom->view(r);
    }
    return {};
  }

  warp::Icaz icaz;
  std::unique_ptr<warp::RetargetZoom> retarget_zoom;
};

// Along one screen axis, the drawn image [lo, hi] either covers the screen [0, side] or lies
// inside it, centred (letterboxed) to within two pixels.
void expect_covered_or_letterboxed(double lo, double hi, double side, const char* axis) {
  const double eps = 1e-6 * std::max(1.0, side);
  if (lo <= eps && hi >= side - eps) return;
  EXPECT_GE(lo, -eps) << axis << ": neither covered nor letterboxed";
  EXPECT_LE(hi, side + eps) << axis << ": neither covered nor letterboxed";
  // The first band is a whole number of pixels (exact pixels at scale 1), the second the rest.
  EXPECT_NEAR(lo, side - hi, 2.0 + eps) << axis << ": bands not centred";
}

void expect_drawable(const warp::Icaz& icaz, const warp::ViewRequest& r, const warp::View& v) {
  const double W = icaz.model().width, H = icaz.model().height;
  ASSERT_FALSE(v.source.triangles.empty());
  ASSERT_EQ(v.warped.size(), v.source.vertices.size());
  ASSERT_EQ(v.screen.size(), v.source.vertices.size());
  double area = 0, x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& t : v.source.triangles) {
    ASSERT_GT(warp::signed_area2(v.screen[t[0]], v.screen[t[1]], v.screen[t[2]]), 0) << "fold-over";
    area += 0.5 * warp::signed_area2(v.source.vertices[t[0]], v.source.vertices[t[1]], v.source.vertices[t[2]]);
  }
  EXPECT_NEAR(area, W * H, 1e-6 * W * H);
  for (const Point& p : v.screen) {
    ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y));
    x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  }
  expect_covered_or_letterboxed(x0, x1, r.screen_width, "x");
  expect_covered_or_letterboxed(y0, y1, r.screen_height, "y");
  EXPECT_FALSE(v.visible.empty());
}

// At zoom 1, ICAZ and traditional zooming show the image 1:1: every vertex on screen is its
// source position moved by one offset.
void expect_one_to_one(const warp::View& v) {
  const double ox = v.screen[0].x - v.source.vertices[0].x, oy = v.screen[0].y - v.source.vertices[0].y;
  for (std::size_t i = 0; i < v.screen.size(); ++i) {
    ASSERT_NEAR(v.screen[i].x - v.source.vertices[i].x, ox, 0.05) << "vertex " << i;
    ASSERT_NEAR(v.screen[i].y - v.source.vertices[i].y, oy, 0.05) << "vertex " << i;
  }
}

class ImageShapes : public ::testing::TestWithParam<Size> {};

TEST_P(ImageShapes, EveryMethodZoomAndScreenGivesADrawableView) {
  const Size s = GetParam();
  Engines engines(model_of(s.w, s.h));
  const warp::Icaz& icaz = engines.icaz;
  for (Size screen : {Size{360, 640}, Size{640, 360}, Size{400, 400}})
    for (double zoom : {0.0, 0.5, 1.0})
      for (Method method : {Method::kIcaz, Method::kTraditional, Method::kRetargetZoom}) {
        SCOPED_TRACE(::testing::Message() << "screen " << screen.w << "×" << screen.h << " zoom " << zoom << " method "
                                          << int(method));
        warp::ViewRequest r;
        r.zoom = zoom, r.cx = s.w / 2.0, r.cy = s.h / 2.0, r.screen_width = screen.w, r.screen_height = screen.h;
        const warp::View v = engines.view(method, r);
        expect_drawable(icaz, r, v);
        if (zoom == 1 && method != Method::kRetargetZoom) expect_one_to_one(v);
      }
  // The significance map exists and covers the image.
  const auto& map = icaz.model().significance;
  EXPECT_GE(map.width, 1);
  EXPECT_GE(map.height, 1);
  EXPECT_EQ(map.values.size(), std::size_t(map.width) * map.height);
}

INSTANTIATE_TEST_SUITE_P(Shapes, ImageShapes,
                         ::testing::Values(Size{1, 1}, Size{2, 2}, Size{16, 16}, Size{64, 64}, Size{100, 100},
                                           Size{109, 3000}, Size{3000, 109}, Size{2, 10000}, Size{10000, 2}),
                         [](const auto& info) { return std::to_string(info.param.w) + "x" + std::to_string(info.param.h); });

// Random image sizes (1…20000 a side, aspect up to 10000:1, at most 50 MP) and screens, seeded:
// the same cases on every run.
TEST(ImageShapesProperty, RandomSizesAndScreensGiveDrawableViews) {
  std::mt19937 rng(20261124);
  auto log_uniform = [&](double lo, double hi) {
    return std::exp(std::uniform_real_distribution<double>(std::log(lo), std::log(hi))(rng));
  };
  for (int c = 0; c < 24; ++c) {
    const int w = std::clamp(int(log_uniform(1, 20000)), 1, 20000);
    const double aspect = log_uniform(1e-4, 1e4);
    const int h = std::clamp(int(std::lround(w / aspect)), std::max(1, int(std::ceil(w / 1e4))),
                             std::min({20000, int(w * 1e4), int(50e6 / w)}));
    Engines engines(model_of(w, h));
    const warp::Icaz& icaz = engines.icaz;
    for (int k = 0; k < 3; ++k) {
      warp::ViewRequest r;
      r.screen_width = int(log_uniform(1, 1024));
      r.screen_height = int(log_uniform(1, 1024));
      r.zoom = std::uniform_real_distribution<double>(0, 1)(rng);
      r.cx = std::uniform_real_distribution<double>(0, w)(rng);
      r.cy = std::uniform_real_distribution<double>(0, h)(rng);
      const Method method = Method(k);
      SCOPED_TRACE(::testing::Message() << "image " << w << "×" << h << " screen " << r.screen_width << "×"
                                        << r.screen_height << " zoom " << r.zoom << " method " << k);
      const warp::View v = engines.view(method, r);
      expect_drawable(icaz, r, v);
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
}

// Zoom 1 on an image smaller than the screen (here only in height) is the 1:1 crop with black
// bands, as traditional zooming letterboxes — not magnified to fill the screen. Checked on the
// rendered pixels.
class OneToOneRender : public ::testing::Test {
 protected:
  tiles::Raster render(int w, int h, int sw, int sh, double cx, double cy, Method method) {
    const tiles::Raster pattern = testing::test_pattern(w, h, 3);
    const std::string file = dir_.path() + "/source.png";
    testing::write_image(file, pattern);
    tiles::Store store(dir_.path() + "/store");
    tiles::ingest_image(store, file, "img", {});
    const auto entry = store.find("img");
    Engines engines(model_of(w, h));
    warp::ViewRequest r;
    r.zoom = 1, r.cx = cx, r.cy = cy, r.screen_width = sw, r.screen_height = sh;
    tiles::PyramidReader reader(16 << 20);
    return warp::render_view(engines.view(method, r), sw, sh, *entry, reader);
  }

  // The screen expected at zoom 1: source pixel (x, y) at screen (x − ox, y − oy), black elsewhere.
  static tiles::Raster expected(const tiles::Raster& source, int sw, int sh, int ox, int oy) {
    tiles::Raster out(sw, sh, 3);
    for (int y = 0; y < sh; ++y)
      for (int x = 0; x < sw; ++x) {
        const int sx = x + ox, sy = y + oy;
        if (sx < 0 || sy < 0 || sx >= source.width || sy >= source.height) continue;
        std::copy_n(source.row(sy) + 3 * sx, 3, out.row(y) + 3 * x);
      }
    return out;
  }

  testing::TempDir dir_;
};

TEST_F(OneToOneRender, PanoramaSmallerThanAPortraitScreenIsLetterboxedNotMagnified) {
  // 1024×512 on 360×640: x is a crop around cx (512 − 180 = 332), y a band of (640 − 512) / 2.
  for (Method method : {Method::kIcaz, Method::kTraditional}) {
    const tiles::Raster shown = render(1024, 512, 360, 640, 512, 256, method);
    const tiles::Raster want = expected(testing::test_pattern(1024, 512, 3), 360, 640, 332, -64);
    EXPECT_EQ(testing::psnr(shown, want), std::numeric_limits<double>::infinity()) << "method " << int(method);
  }
}

TEST_F(OneToOneRender, TinyImageIsCentredOneToOne) {
  const tiles::Raster shown = render(64, 64, 360, 640, 32, 32, Method::kIcaz);
  const tiles::Raster want = expected(testing::test_pattern(64, 64, 3), 360, 640, -148, -288);
  EXPECT_EQ(testing::psnr(shown, want), std::numeric_limits<double>::infinity());
}

// 64 lines (the limit) crossing on an 8 × 8 grid, horizontal, vertical and oblique: CGAL's
// refinement meets a flat face there. The lines are refused as bad input — the process used to
// die of a null dereference inside the mesher.
TEST(CoarseMeshLines, CrossingsCGALCannotMeshAreRefusedNotACrash) {
  const double w = 5400, h = 2500, len = 16.0 / 64 * std::max(w, h);
  std::vector<warp::Segment> lines;
  for (int i = 0; i < 64; ++i) {
    const double cx = w * (0.1 + 0.8 * (i % 8) / 7), cy = h * (0.1 + 0.8 * (i / 8) / 7);
    const double angle = (i % 3 == 0 ? 0 : i % 3 == 1 ? 90 : 30) * M_PI / 180;
    const double dx = std::cos(angle) * len / 2, dy = std::sin(angle) * len / 2;
    lines.push_back({{cx - dx, cy - dy}, {cx + dx, cy + dy}});
  }
  EXPECT_THROW(warp::build_coarse_mesh(w, h, lines), std::invalid_argument);
  lines.resize(21);  // the first 21 mesh
  EXPECT_NO_THROW(warp::build_coarse_mesh(w, h, lines));
}

}  // namespace
}  // namespace zoomwarp
