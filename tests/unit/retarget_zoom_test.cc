// method=retarget-zoom (warp/methods/retarget_zoom): Retargeting+Zooming on a uniform mesh as
// fine as ICAZ's finest level [ICAZ §6.1].
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "tiles/pyramid_reader.h"
#include "warp/core/stop_token.h"
#include "warp/meshing/coarse_mesh.h"
#include "warp/methods/retarget_zoom/retarget_zoom.h"
#include "warp/render/render.h"

namespace zoomwarp {
namespace {

using warp::Point;

warp::ImageModel sample_model(const std::string& file, std::vector<warp::Segment> lines = {}) {
  const tiles::Raster full = testing::load_image(testing::samples_dir() + "/" + file);
  const double f = std::min(1.0, double(warp::kSignificanceMaxSide) / std::max(full.width, full.height));
  const tiles::Raster small = testing::resize(full, std::max(1, int(full.width * f)), std::max(1, int(full.height * f)));
  return warp::make_image_model(small, full.width, full.height, lines);
}

const warp::ImageModel& boats() {
  static const warp::ImageModel m = sample_model("boats_lake_sunset.jpg", {{{0, 992}, {2560, 992}}, {{1400, 300}, {2400, 1300}}});
  return m;
}

TEST(RetargetZoom, AtTheImagesAspectItIsTheIdentityAndZoomOneIsTheCrop) {
  warp::RetargetZoom rz(boats(), boats().significance);
  warp::ViewRequest r;
  r.screen_width = 480, r.screen_height = 300;  // 16:10, as the image
  r.cx = 900, r.cy = 500;
  for (double z : {0.0, 1.0}) {
    r.zoom = z;
    const warp::View v = rz.view(r);
    for (std::size_t i = 0; i < v.warped.size(); ++i) {
      ASSERT_NEAR(v.warped[i].x, v.source.vertices[i].x, 1e-6) << "vertex " << i;
      ASSERT_NEAR(v.warped[i].y, v.source.vertices[i].y, 1e-6) << "vertex " << i;
    }
  }
  // z = 1: the 1:1 crop centred on the view centre.
  const warp::View v = rz.view(r);
  for (std::size_t i = 0; i < v.screen.size(); ++i) {
    ASSERT_NEAR(v.screen[i].x, v.source.vertices[i].x - (900 - 240), 1e-6);
    ASSERT_NEAR(v.screen[i].y, v.source.vertices[i].y - (500 - 150), 1e-6);
  }
}

TEST(RetargetZoom, ItsMeshIsTheFineUniformMeshAndZoomZeroListsEveryTriangle) {
  const warp::ImageModel& m = boats();
  warp::RetargetZoom rz(m, m.significance);
  // Boats (4.1 MP) keeps its forest down to the 500 px² of a view at 100 %.
  const double leaf = warp::finest_stored_leaf_area(m);
  EXPECT_LE(leaf, 500);
  warp::CoarseMeshOptions fine;
  fine.max_triangle_area = leaf;
  fine.vertex_budget = warp::RetargetZoom::kMaxVertices;
  const warp::CoarseMesh uniform = warp::build_coarse_mesh(m.width, m.height, m.lines, fine);
  warp::ViewRequest r;
  r.screen_width = 360, r.screen_height = 640, r.cx = 1280, r.cy = 800;
  const warp::View v = rz.view(r);
  EXPECT_EQ(v.source.triangles.size(), uniform.mesh.triangles.size());
  EXPECT_EQ(v.visible.size(), v.source.triangles.size()) << "z = 0 shows every triangle";
  EXPECT_GT(v.source.vertices.size(), 5 * m.coarse.mesh.vertices.size()) << "finer than the coarsest mesh";
  EXPECT_LE(int(v.source.vertices.size()), warp::RetargetZoom::kMaxVertices);
  std::printf("[ figures ] boats: uniform mesh %zu vertices, %zu triangles (coarsest: %zu vertices); %d iterations\n",
              v.source.vertices.size(), v.source.triangles.size(), m.coarse.mesh.vertices.size(), v.coarse_stats.iterations);
}

TEST(RetargetZoom, CapsTheMeshOfALargeImage) {
  // The world map's size (5400 × 2500): 500 px² would be ~30 000 vertices; a 4× larger image
  // keeps the cap by larger triangles.
  const tiles::Raster small = testing::test_pattern(1024, 474, 3);
  const warp::ImageModel m = warp::make_image_model(small, 10800, 5000);
  warp::RetargetZoom rz(m, m.significance);
  EXPECT_LE(int(rz.mesh().vertices.size()), warp::RetargetZoom::kMaxVertices);
  EXPECT_GT(int(rz.mesh().vertices.size()), warp::RetargetZoom::kMaxVertices / 2);
}

TEST(RetargetZoom, FillsTheScreenWithoutFoldsAtEveryZoomAndKeepsLinesStraight) {
  const warp::ImageModel& m = boats();
  warp::RetargetZoom rz(m, m.significance);
  for (auto [sw, sh] : {std::pair{360, 640}, std::pair{640, 360}})
    for (double z : {0.0, 0.5, 1.0}) {
      warp::ViewRequest r;
      r.zoom = z, r.cx = 1800, r.cy = 700, r.screen_width = sw, r.screen_height = sh;
      const warp::View v = rz.view(r);
      SCOPED_TRACE(::testing::Message() << sw << "×" << sh << " z=" << z);
      EXPECT_NEAR(v.geometry.target_width / v.geometry.target_height, double(sw) / sh, 1e-9);
      double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
      for (const Point& p : v.screen) x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
      EXPECT_LE(x0, 1e-6);
      EXPECT_GE(x1, sw - 1e-6);
      EXPECT_LE(y0, 1e-6);
      EXPECT_GE(y1, sh - 1e-6);
      for (const auto& t : v.source.triangles) ASSERT_GT(warp::signed_area2(v.screen[t[0]], v.screen[t[1]], v.screen[t[2]]), 0);
      // The horizon is a chain of mesh edges: straight in the warped image to 0.5 px.
      const std::vector<int> chain = warp::vertices_on_segment(v.source, m.lines[0]);
      ASSERT_GE(chain.size(), 10u);
      for (int i : chain) EXPECT_NEAR(v.warped[i].y, v.warped[chain[0]].y, 0.5);
    }
}

// Retargeting+Zooming [ICAZ §6.1] keeps the z = 0 distortion at every zoom (ICAZ unrolls it):
// each edge on screen at zoom z is its z = 0 edge times one factor, the ratio of the geometric
// curve's magnifications s(z) = s0·(1/s0)^z, s0 = min(sw/W', sh/H') — computed here, not read
// from the view.
TEST(RetargetZoom, ZoomingKeepsTheZoomZeroWarp) {
  warp::RetargetZoom rz(boats(), boats().significance);
  warp::ViewRequest r;
  r.screen_width = 360, r.screen_height = 640;
  r.cx = 1200, r.cy = 700;
  const warp::View v0 = rz.view(r);
  const double tw = std::sqrt(2560.0 * 1600 * 360 / 640), th = std::sqrt(2560.0 * 1600 * 640 / 360);
  const double s0 = std::min(360 / tw, 640 / th);
  for (double z : {0.25, 0.5, 1.0}) {
    SCOPED_TRACE("z=" + std::to_string(z));
    r.zoom = z;
    const warp::View v = rz.view(r);
    ASSERT_EQ(v.source.triangles, v0.source.triangles);
    const double k = std::pow(1 / s0, z);
    double worst = 0;
    for (const auto& t : v.source.triangles)
      for (int e = 0; e < 3; ++e) {
        const int i = t[e], j = t[(e + 1) % 3];
        worst = std::max({worst, std::abs((v.screen[j].x - v.screen[i].x) - k * (v0.screen[j].x - v0.screen[i].x)),
                          std::abs((v.screen[j].y - v.screen[i].y) - k * (v0.screen[j].y - v0.screen[i].y))});
      }
    EXPECT_LT(worst, 1e-6) << "the z = 0 warp is not what is zoomed";
  }
}

TEST(RetargetZoom, TheSaliencyMapDrivesTheWarp) {
  const warp::ImageModel& m = boats();
  warp::SignificanceMap inverted = m.significance;
  for (float& v : inverted.values) v = 1 - v;
  warp::RetargetZoom a(m, m.significance), b(m, inverted);
  warp::ViewRequest r;
  r.screen_width = 360, r.screen_height = 640, r.cx = 1280, r.cy = 800;
  const warp::View va = a.view(r), vb = b.view(r);
  double moved = 0;
  for (std::size_t i = 0; i < va.warped.size(); ++i)
    moved = std::max(moved, std::hypot(va.warped[i].x - vb.warped[i].x, va.warped[i].y - vb.warped[i].y));
  EXPECT_GT(moved, 20) << "warped pixels";
}

TEST(RetargetZoom, RefusesBadRequestsAndStops) {
  warp::RetargetZoom rz(boats(), boats().significance);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (auto bad : std::vector<std::function<void(warp::ViewRequest&)>>{
           [&](auto& r) { r.zoom = nan; }, [&](auto& r) { r.cx = nan; }, [](auto& r) { r.screen_width = 0; },
           [](auto& r) { r.screen_width = 100000; }}) {
    warp::ViewRequest r;
    bad(r);
    EXPECT_THROW(rz.view(r), std::invalid_argument);
  }
  const warp::StopToken expired(warp::StopToken::Clock::now() - std::chrono::seconds(1));
  warp::ViewRequest r;
  r.screen_width = 300, r.screen_height = 700, r.stop = &expired;
  EXPECT_THROW(rz.view(r), warp::Stopped);
  r.stop = nullptr;
  EXPECT_NO_THROW(rz.view(r)) << "a stopped view leaves the engine usable";
}

// /viewport draws straight from the kept mesh and warp (RetargetZoom::render) rather than from a
// View: it must show exactly the picture of the view /mesh describes, zoomed out (every triangle,
// each a few screen pixels), zoomed in with the centre clamped at a corner, and portrait.
TEST(RetargetZoom, ItsViewportIsItsViewRendered) {
  testing::TempDir dir;
  tiles::Store store(dir.path() + "/store");
  tiles::ingest_image(store, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", {});
  const auto entry = store.find("boats");
  ASSERT_TRUE(entry);
  tiles::PyramidReader reader(64 << 20);
  warp::RetargetZoom rz(boats(), boats().significance);
  struct Case {
    double zoom, cx, cy;
    int sw, sh;
  };
  for (const Case c : {Case{0, 1280, 800, 480, 360}, Case{0.3, 700, 400, 480, 360}, Case{0.7, 2500, 1550, 480, 360},
                       Case{1, 10, 10, 480, 360}, Case{0.2, 1900, 900, 360, 640}}) {
    SCOPED_TRACE(::testing::Message() << "zoom " << c.zoom << " screen " << c.sw << "×" << c.sh);
    warp::ViewRequest r;
    r.zoom = c.zoom, r.cx = c.cx, r.cy = c.cy, r.screen_width = c.sw, r.screen_height = c.sh;
    const tiles::Raster viewport = rz.render(r, *entry, reader);
    const tiles::Raster of_view = warp::render_view(rz.view(r), c.sw, c.sh, *entry, reader);
    ASSERT_EQ(viewport.width, c.sw);
    ASSERT_EQ(viewport.height, c.sh);
    EXPECT_TRUE(viewport.pixels == of_view.pixels);
  }
}

}  // namespace
}  // namespace zoomwarp
