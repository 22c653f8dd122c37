// method=retarget-zoom (warp/methods/retarget_zoom): Retargeting+Zooming on a uniform mesh as
// fine as ICAZ's finest level [ICAZ §6.1].
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "tiles/pyramid_reader.h"
#include "warp/core/stop_token.h"
#include "warp/core/triangle_locator.h"
#include "warp/meshing/coarse_mesh.h"
#include "warp/methods/retarget_zoom/retarget_zoom.h"
#include "warp/render/inverse_map.h"
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

// A store with one sample ingested, and its RetargetZoom: what the /viewport tests draw from.
struct Sample {
  testing::TempDir dir;
  tiles::Store store{dir.path() + "/store"};
  std::shared_ptr<const tiles::ImageEntry> entry;
  tiles::PyramidReader reader{64 << 20};
  warp::RetargetZoom rz;

  Sample(const std::string& file, const warp::ImageModel& model) : rz(model, model.significance) {
    tiles::ingest_image(store, testing::samples_dir() + "/" + file, "sample", {});
    entry = store.find("sample");
  }
};

// Whether view v is beyond the inverse map's reach — a screen pixel smaller than its cells — so
// RetargetZoom::render draws its triangles.
bool zoomed_in_past_the_map(const warp::View& v) {
  const warp::InverseMap grid =
      warp::inverse_map_grid(v.geometry.target_width, v.geometry.target_height, warp::RetargetZoom::kMapNodes);
  return !warp::grid_serves(grid, v.geometry.screen_scale);
}

// /viewport zoomed in (few, large triangles) draws straight from the kept mesh and warp
// (RetargetZoom::render) rather than from a View: it must show exactly the picture of the view
// /mesh describes — zoomed in half way, with the centre clamped at a corner, 1:1, and portrait.
TEST(RetargetZoom, ItsZoomedInViewportIsItsViewRendered) {
  Sample boats_sample("boats_lake_sunset.jpg", boats());
  ASSERT_TRUE(boats_sample.entry);
  struct Case {
    double zoom, cx, cy;
    int sw, sh;
  };
  for (const Case c : {Case{0.5, 700, 400, 480, 360}, Case{0.7, 2500, 1550, 480, 360}, Case{1, 10, 10, 480, 360},
                       Case{0.6, 1900, 900, 360, 640}}) {
    SCOPED_TRACE(::testing::Message() << "zoom " << c.zoom << " screen " << c.sw << "×" << c.sh);
    warp::ViewRequest r;
    r.zoom = c.zoom, r.cx = c.cx, r.cy = c.cy, r.screen_width = c.sw, r.screen_height = c.sh;
    const warp::View v = boats_sample.rz.view(r);
    ASSERT_TRUE(zoomed_in_past_the_map(v));
    const tiles::Raster viewport = boats_sample.rz.render(r, *boats_sample.entry, boats_sample.reader);
    const tiles::Raster of_view = warp::render_view(v, c.sw, c.sh, *boats_sample.entry, boats_sample.reader);
    ASSERT_EQ(viewport.width, c.sw);
    ASSERT_EQ(viewport.height, c.sh);
    EXPECT_TRUE(viewport.pixels == of_view.pixels);
  }
}

// The largest distance, in screen pixels, between a screen pixel centre p and where the map's
// source position for p lands on screen through the triangle that holds p (its exact barycentric
// source position lands on p itself), over the pixels the map path draws.
double worst_screen_error(const warp::View& v, const warp::InverseMap& map, int sw, int sh) {
  const double s = v.geometry.screen_scale;
  const warp::ZoomPlacement place{s, -v.view_x * s, -v.view_y * s};
  const warp::ScreenPositions at = warp::screen_positions(map, place, sw, sh);
  const warp::Mesh on_screen{v.screen, v.source.triangles};
  const warp::TriangleLocator locator(on_screen);
  double worst = 0;
  for (int j = 0; j < at.height; ++j)
    for (int i = 0; i < at.width; ++i) {
      const Point p{at.x0 + i + 0.5, at.y0 + j + 0.5};
      const warp::MeshPoint exact = locator.find(p);
      if (exact.triangle < 0) return 1e9;
      const warp::Triangle& t = v.source.triangles[exact.triangle];
      const std::size_t n = 2 * (std::size_t(j) * at.width + i);
      const Point mapped{at.uv[n], at.uv[n + 1]};
      const auto& src = v.source.vertices;
      const Point back = warp::combine(warp::barycentric(mapped, src[t[0]], src[t[1]], src[t[2]]), v.screen[t[0]],
                                       v.screen[t[1]], v.screen[t[2]]);
      worst = std::max(worst, std::hypot(back.x - p.x, back.y - p.y));
    }
  return worst;
}

// /viewport zoomed out (a screen pixel spans a node of the warp's inverse map) is drawn through
// the map: within 40 dB of the exact picture (render_view of its /mesh view) and its source
// positions within a quarter of a screen pixel of the exact piecewise-linear inverse, from zoom 0
// to the switch, landscape and portrait, centred and at the corners, on two images.
TEST(RetargetZoom, ItsZoomedOutViewportIsItsViewRenderedWithinAQuarterPixel) {
  int views = 0;
  for (const char* file : {"boats_lake_sunset.jpg", "interior_wine_djembe_tall.jpg"}) {
    const warp::ImageModel model = sample_model(file);
    Sample sample(file, model);
    ASSERT_TRUE(sample.entry);
    for (auto [sw, sh] : {std::pair{480, 360}, std::pair{360, 640}}) {
      warp::ViewRequest r;
      r.screen_width = sw, r.screen_height = sh;
      const warp::View zero = sample.rz.view(r);
      const double tw = zero.geometry.target_width, th = zero.geometry.target_height;
      const warp::InverseMap map = warp::build_inverse_map(zero.source, zero.warped, tw, th, warp::RetargetZoom::kMapNodes);
      // The zoom of the switch on the geometric curve s(z) = s0·(1/s0)^z: the largest scale the map
      // serves, where a screen pixel spans a node or its error reaches kMaxMapError screen px.
      const double switch_scale = std::min({map.per_x, map.per_y, warp::kMaxMapError / map.max_error});
      const double s0 = zero.geometry.screen_scale, switch_zoom = std::log(switch_scale / s0) / std::log(1 / s0);
      std::printf("[ figures ] %s %d×%d: map %d×%d nodes, error %.2f warped px, switch at zoom %.3f\n", file, sw, sh,
                  map.cols, map.rows, map.max_error, switch_zoom);
      if (switch_zoom < 0) continue;  // a warp too strong for the map at this size: triangles at every zoom
      for (double f : {0.0, 0.33, 0.66, 0.99})
        for (Point c : {Point{model.width / 2, model.height / 2}, Point{0, 0}, Point{model.width, model.height}}) {
          if (f == 0 && c.x != 0) continue;  // zoom 0 shows the whole image wherever the centre is
          r.zoom = f * switch_zoom, r.cx = c.x, r.cy = c.y;
          SCOPED_TRACE(::testing::Message() << file << " " << sw << "×" << sh << " zoom " << r.zoom << " centre " << c.x << "," << c.y);
          const warp::View v = sample.rz.view(r);
          ASSERT_TRUE(warp::map_serves(map, v.geometry.screen_scale));
          const tiles::Raster viewport = sample.rz.render(r, *sample.entry, sample.reader);
          const tiles::Raster exact = warp::render_view(v, sw, sh, *sample.entry, sample.reader);
          ASSERT_EQ(viewport.width, sw);
          ASSERT_EQ(viewport.height, sh);
          const double psnr = testing::psnr(viewport, exact), error = worst_screen_error(v, map, sw, sh);
          EXPECT_GE(psnr, 40);
          EXPECT_LE(error, 0.25);
          std::printf("[ figures ] %s %d×%d zoom %.3f: PSNR %.1f dB, worst position error %.3f screen px\n", file, sw, sh,
                      r.zoom, psnr, error);
          ++views;
        }
    }
  }
  EXPECT_GE(views, 20);
}

}  // namespace
}  // namespace zoomwarp
