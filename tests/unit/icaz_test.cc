// The ICAZ operator over sweeps of zoom levels, view centres, screens and images (wide, tall,
// ordinary), with and without line constraints. Every view must be something a viewer can draw:
// no fold-overs, the screen covered, the mesh conforming and inside the target, z = 1 an exact
// crop, lines straight, the view centre at the screen centre, and small zoom steps small moves.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/icaz/icaz.h"

namespace zoomwarp {
namespace {

using warp::Point;

struct Sample {
  const char* file;
  std::vector<warp::Segment> lines;  // in fractions of width/height, scaled below
};

std::shared_ptr<warp::Icaz> engine(const std::string& file, bool with_lines) {
  static std::map<std::pair<std::string, bool>, std::shared_ptr<warp::Icaz>> cache;
  auto& e = cache[{file, with_lines}];
  if (e) return e;
  const tiles::Raster full = testing::load_image(testing::samples_dir() + "/" + file);
  const double f = std::min(1.0, 1024.0 / std::max(full.width, full.height));
  const tiles::Raster small = testing::resize(full, int(full.width * f), int(full.height * f));
  const double W = full.width, H = full.height;
  std::vector<warp::Segment> lines;
  if (with_lines) {
    lines = {{{0, 0.62 * H}, {W, 0.62 * H}},                     // a horizon
             {{0.3 * W, 0.1 * H}, {0.3 * W, 0.9 * H}},           // a vertical
             {{0.55 * W, 0.2 * H}, {0.95 * W, 0.8 * H}}};        // an oblique
  }
  e = std::make_shared<warp::Icaz>(warp::make_image_model(small, W, H, lines));
  return e;
}

bool inside(const Point& p, const Point& a, const Point& b, const Point& c) {
  const double d0 = warp::signed_area2(a, b, p), d1 = warp::signed_area2(b, c, p), d2 = warp::signed_area2(c, a, p);
  return d0 >= -1e-6 && d1 >= -1e-6 && d2 >= -1e-6;
}

// Screen position of a source point in a view (through the triangle holding it), if any.
std::optional<Point> to_screen(const warp::View& v, const Point& s) {
  for (const auto& t : v.source.triangles) {
    const Point &a = v.source.vertices[t[0]], &b = v.source.vertices[t[1]], &c = v.source.vertices[t[2]];
    if (!inside(s, a, b, c)) continue;
    const double d = warp::signed_area2(a, b, c);
    const double l0 = warp::signed_area2(s, b, c) / d, l1 = warp::signed_area2(a, s, c) / d, l2 = 1 - l0 - l1;
    return Point{l0 * v.screen[t[0]].x + l1 * v.screen[t[1]].x + l2 * v.screen[t[2]].x,
                 l0 * v.screen[t[0]].y + l1 * v.screen[t[1]].y + l2 * v.screen[t[2]].y};
  }
  return std::nullopt;
}

void check_view(const warp::Icaz& icaz, const warp::ViewRequest& r, const warp::View& v) {
  const double W = icaz.model().width, H = icaz.model().height;
  const auto& m = v.source;
  // No fold-overs, and the source mesh is a conforming tiling of the image.
  double area = 0;
  std::map<std::pair<int, int>, int> edges;
  for (const auto& t : m.triangles) {
    ASSERT_GT(warp::signed_area2(v.warped[t[0]], v.warped[t[1]], v.warped[t[2]]), 0) << "fold-over";
    area += 0.5 * warp::signed_area2(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]);
    for (int k = 0; k < 3; ++k) ++edges[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}];
  }
  EXPECT_NEAR(area, W * H, 1e-6 * W * H);
  for (const auto& [e, n] : edges) {
    const Point &a = m.vertices[e.first], &b = m.vertices[e.second];
    const bool boundary = (a.x == 0 && b.x == 0) || (a.x == W && b.x == W) || (a.y == 0 && b.y == 0) || (a.y == H && b.y == H);
    ASSERT_EQ(n, boundary ? 1 : 2) << "T-junction or hole";
  }
  // Inside the target, boundary on the boundary.
  const double tw = v.geometry.target_width, th = v.geometry.target_height;
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const Point &s = m.vertices[i], &p = v.warped[i];
    ASSERT_TRUE(p.x >= -1e-6 && p.x <= tw + 1e-6 && p.y >= -1e-6 && p.y <= th + 1e-6);
    if (s.x == 0) {
      ASSERT_NEAR(p.x, 0, 1e-6);
    }
    if (s.x == W) {
      ASSERT_NEAR(p.x, tw, 1e-6);
    }
    if (s.y == 0) {
      ASSERT_NEAR(p.y, 0, 1e-6);
    }
    if (s.y == H) {
      ASSERT_NEAR(p.y, th, 1e-6);
    }
  }
  // The visible triangles cover the screen (a grid of screen points, corners included), except
  // for centred letterbox bands along an axis where the warped image is smaller than the screen
  // at this scale (an image smaller than the screen near z = 1). Points within a pixel of a
  // band's edge are not judged: bands are whole pixels.
  const double shown_w = std::min<double>(r.screen_width, tw * v.geometry.screen_scale);
  const double shown_h = std::min<double>(r.screen_height, th * v.geometry.screen_scale);
  const double band_x = (r.screen_width - shown_w) / 2, band_y = (r.screen_height - shown_h) / 2;
  auto near_band_edge = [](double p, double band, double shown) {
    return band > 0 && (std::abs(p - band) < 1 || std::abs(p - band - shown) < 1);
  };
  for (int gy = 0; gy <= 12; ++gy)
    for (int gx = 0; gx <= 16; ++gx) {
      const Point p{r.screen_width * gx / 16.0, r.screen_height * gy / 12.0};
      if (near_band_edge(p.x, band_x, shown_w) || near_band_edge(p.y, band_y, shown_h)) continue;
      const bool in_image = p.x >= band_x && p.x <= band_x + shown_w && p.y >= band_y && p.y <= band_y + shown_h;
      bool covered = false;
      for (int f : v.visible) {
        const auto& t = m.triangles[f];
        if (inside(p, v.screen[t[0]], v.screen[t[1]], v.screen[t[2]])) {
          covered = true;
          break;
        }
      }
      ASSERT_EQ(covered, in_image) << (in_image ? "black band" : "image drawn over the letterbox band")
                                   << " at screen (" << p.x << ", " << p.y << ")";
    }
  // The view centre is at the screen centre unless the viewing area had to move.
  if (!v.centre_clamped) {
    auto c = to_screen(v, {r.cx, r.cy});
    ASSERT_TRUE(c);
    EXPECT_NEAR(c->x, r.screen_width / 2.0, 0.5);
    EXPECT_NEAR(c->y, r.screen_height / 2.0, 0.5);
  }
  // z = 1: the identity crop.
  if (r.zoom == 1 && W >= r.screen_width && H >= r.screen_height) {
    const double ox = std::clamp(r.cx - r.screen_width / 2.0, 0.0, W - r.screen_width);
    const double oy = std::clamp(r.cy - r.screen_height / 2.0, 0.0, H - r.screen_height);
    for (std::size_t i = 0; i < m.vertices.size(); ++i) {
      ASSERT_NEAR(v.screen[i].x, m.vertices[i].x - ox, 0.5);
      ASSERT_NEAR(v.screen[i].y, m.vertices[i].y - oy, 0.5);
    }
  }
  // Lines stay straight on screen (within 1 px of their chord), for visible line vertices.
  for (const auto& line : icaz.model().lines) {
    const std::vector<int> on = warp::vertices_on_segment(m, line);
    ASSERT_GE(on.size(), 2u);
    const Point a = v.screen[on.front()], b = v.screen[on.back()];
    const double chord = std::hypot(b.x - a.x, b.y - a.y);
    for (int i : on) {
      const Point& p = v.screen[i];
      if (p.x < 0 || p.x > r.screen_width || p.y < 0 || p.y > r.screen_height) continue;
      EXPECT_LT(std::abs((p.x - a.x) * (b.y - a.y) - (p.y - a.y) * (b.x - a.x)) / chord, 1.0) << "bent line";
    }
  }
}

struct SweepCase {
  const char* file;
  int sw, sh;
  bool lines;
};

class IcazSweep : public ::testing::TestWithParam<SweepCase> {};

TEST_P(IcazSweep, EveryViewIsDrawable) {
  const SweepCase c = GetParam();
  auto icaz = engine(c.file, c.lines);
  const double W = icaz->model().width, H = icaz->model().height;
  const Point centres[] = {{W / 2, H / 2}, {0.08 * W, 0.1 * H}, {0.85 * W, 0.7 * H}};
  for (const Point& centre : centres)
    for (double z : {0.0, 0.2, 0.4, 0.6, 0.8, 0.9, 1.0}) {
      SCOPED_TRACE("z=" + std::to_string(z) + " centre=(" + std::to_string(centre.x) + "," + std::to_string(centre.y) + ")");
      warp::ViewRequest r;
      r.zoom = z, r.cx = centre.x, r.cy = centre.y, r.screen_width = c.sw, r.screen_height = c.sh;
      const warp::View v = icaz->view(r);
      check_view(*icaz, r, v);
      if (HasFatalFailure()) return;
    }
}

INSTANTIATE_TEST_SUITE_P(
    Images, IcazSweep,
    ::testing::Values(SweepCase{"boats_lake_sunset.jpg", 480, 360, false}, SweepCase{"boats_lake_sunset.jpg", 360, 640, true},
                      SweepCase{"pano_grossmugl_field_4to1.png", 480, 360, true},
                      SweepCase{"pano_grossmugl_field_4to1.png", 360, 640, false},
                      SweepCase{"interior_wine_djembe_tall.jpg", 480, 360, true},
                      SweepCase{"interior_wine_djembe_tall.jpg", 360, 640, false}),
    [](const auto& info) {
      std::string n = info.param.file;
      n = n.substr(0, n.find('_')) + "_" + std::to_string(info.param.sw) + "x" + std::to_string(info.param.sh) +
          (info.param.lines ? "_lines" : "");
      return n;
    });

// Continuity: a zoom step of 0.01 moves every visible point by little. The bound, 3% of the
// screen diagonal, covers the magnification step of the geometric curve (≤ 2.5% at the screen
// edge for these images) plus the change of the warp itself.
TEST(IcazContinuity, SmallZoomStepsMovePointsLittle) {
  for (const char* file : {"boats_lake_sunset.jpg", "pano_grossmugl_field_4to1.png"}) {
    auto icaz = engine(file, true);
    const double W = icaz->model().width, H = icaz->model().height;
    double worst = 0;
    for (double z = 0; z < 0.995; z += 0.1) {
      warp::ViewRequest a;
      a.zoom = z, a.cx = 0.45 * W, a.cy = 0.55 * H;
      warp::ViewRequest b = a;
      b.zoom = z + 0.01;
      const auto va = icaz->view(a), vb = icaz->view(b);
      for (int gy = 1; gy < 10; ++gy)
        for (int gx = 1; gx < 10; ++gx) {
          const Point s{W * gx / 10, H * gy / 10};
          auto pa = to_screen(va, s), pb = to_screen(vb, s);
          if (!pa || !pb || pa->x < 0 || pa->x > 480 || pa->y < 0 || pa->y > 360) continue;
          worst = std::max(worst, std::hypot(pa->x - pb->x, pa->y - pb->y));
        }
    }
    std::printf("[ figures ] %s: largest move of a visible point for a 0.01 zoom step: %.2f px\n", file, worst);
    EXPECT_LT(worst, 0.03 * std::hypot(480, 360)) << file;
  }
}

// The fine level is solved only near the viewing area (IcazOptions::solve_margin); what is on
// screen stays close to solving the whole refined mesh.
TEST(IcazLocalSolve, VisibleVerticesMatchTheWholeSolve) {
  const auto shared = engine("boats_lake_sunset.jpg", true);
  warp::Icaz local(shared->model());
  warp::IcazOptions whole_options;
  whole_options.solve_margin = std::numeric_limits<double>::infinity();
  warp::Icaz whole(shared->model(), whole_options);
  const double W = shared->model().width, H = shared->model().height;
  double worst = 0;
  for (double z : {0.4, 0.7, 0.9})
    for (double cx : {0.3, 0.6}) {
      warp::ViewRequest r;
      r.zoom = z, r.cx = cx * W, r.cy = 0.45 * H;
      const auto a = local.view(r), b = whole.view(r);
      ASSERT_EQ(a.forest_vertex, b.forest_vertex) << "the same cut";
      for (int f : a.visible)
        for (int v : a.source.triangles[f])
          worst = std::max(worst, std::hypot(a.screen[v].x - b.screen[v].x, a.screen[v].y - b.screen[v].y));
    }
  std::printf("[ figures ] local vs whole fine solve: largest difference of a visible vertex %.2f px\n", worst);
  EXPECT_LT(worst, 2.0);
}

// Memory cap: nodes made lazily beyond the stored forest are forgotten once there are too many;
// views keep working, and a geomorph across the trim is refused rather than wrong.
TEST(IcazForestCap, LazyNodesAreForgottenAndOldViewsRefused) {
  const auto shared = engine("boats_lake_sunset.jpg", false);
  warp::ImageModel m = shared->model();
  m.forest = warp::Forest(m.coarse.mesh);  // nothing stored below the roots: every node is lazy
  m.node_mean.resize(std::size_t(m.forest.kept_nodes()));
  warp::IcazOptions options;
  options.max_forest_nodes = m.forest.kept_nodes() + 200;
  warp::Icaz icaz(m, options);
  warp::ViewRequest r;
  r.zoom = 0.9, r.cx = 600, r.cy = 500;
  const auto first = icaz.view(r);
  r.cx = 2000;
  const auto second = icaz.view(r);  // the forest grew past the cap during the first view
  EXPECT_NE(first.forest_epoch, second.forest_epoch);
  EXPECT_THROW(icaz.geomorph(first, second), std::invalid_argument);
  const auto g = icaz.geomorph(r, r);
  EXPECT_EQ(g.from.size(), g.source.vertices.size());
}

TEST(IcazZoomCurve, EndpointsAndMonotonicMagnification) {
  const auto g0 = warp::zoom_geometry(5400, 2500, 480, 360, 0);
  EXPECT_NEAR(g0.target_width / g0.target_height, 480.0 / 360, 1e-9);
  EXPECT_NEAR(g0.view_width, g0.target_width, 1e-6);
  EXPECT_NEAR(g0.target_width * g0.target_height, 5400.0 * 2500, 1e-3);
  const auto g1 = warp::zoom_geometry(5400, 2500, 480, 360, 1);
  EXPECT_NEAR(g1.target_width, 5400, 1e-6);
  EXPECT_NEAR(g1.view_width, 480, 1e-6);
  EXPECT_NEAR(g1.screen_scale, 1, 1e-12);
  double last = 0;
  for (double z = 0; z <= 1.0001; z += 0.05)
    for (auto curve : {warp::ZoomCurve::kLinear, warp::ZoomCurve::kGeometric}) {
      const auto g = warp::zoom_geometry(5400, 2500, 480, 360, z, curve);
      EXPECT_LE(g.view_width, g.target_width + 1e-9);
      EXPECT_LE(g.view_height, g.target_height + 1e-9);
      if (curve == warp::ZoomCurve::kGeometric) {
        EXPECT_GT(g.screen_scale, last);
        last = g.screen_scale;
      }
    }
  // Geometric: equal steps multiply the magnification by the same factor.
  const double r1 = warp::zoom_geometry(5400, 2500, 480, 360, 0.3).screen_scale / warp::zoom_geometry(5400, 2500, 480, 360, 0.2).screen_scale;
  const double r2 = warp::zoom_geometry(5400, 2500, 480, 360, 0.7).screen_scale / warp::zoom_geometry(5400, 2500, 480, 360, 0.6).screen_scale;
  EXPECT_NEAR(r1, r2, 1e-9);
}

}  // namespace
}  // namespace zoomwarp

namespace zoomwarp {
namespace {

// Geomorphing: the common refinement holds every vertex of both views, reproduces each view's
// positions exactly, and draws each view unfolded.
TEST(IcazGeomorph, CommonRefinementCarriesBothViews) {
  auto icaz = engine("boats_lake_sunset.jpg", true);
  const double W = icaz->model().width, H = icaz->model().height;
  warp::ViewRequest a, b;
  a.zoom = 0.3, a.cx = 0.3 * W, a.cy = 0.6 * H;
  b.zoom = 0.7, b.cx = 0.7 * W, b.cy = 0.4 * H;
  const warp::View va = icaz->view(a), vb = icaz->view(b);
  const warp::Geomorph g = icaz->geomorph(va, vb);
  std::map<int, int> index;
  for (int i = 0; i < int(g.forest_vertex.size()); ++i) index[g.forest_vertex[i]] = i;
  EXPECT_GE(g.source.vertices.size(), std::max(va.source.vertices.size(), vb.source.vertices.size()));
  for (const auto* v : {&va, &vb})
    for (int i = 0; i < int(v->forest_vertex.size()); ++i) {
      auto it = index.find(v->forest_vertex[i]);
      ASSERT_NE(it, index.end()) << "a vertex of a view is missing from the common refinement";
      const Point& p = (v == &va ? g.from : g.to)[it->second];
      EXPECT_EQ(p.x, v->screen[i].x);
      EXPECT_EQ(p.y, v->screen[i].y);
    }
  double area = 0;
  for (const auto& t : g.source.triangles) {
    area += 0.5 * warp::signed_area2(g.source.vertices[t[0]], g.source.vertices[t[1]], g.source.vertices[t[2]]);
    EXPECT_GT(warp::signed_area2(g.from[t[0]], g.from[t[1]], g.from[t[2]]), 0);
    EXPECT_GT(warp::signed_area2(g.to[t[0]], g.to[t[1]], g.to[t[2]]), 0);
  }
  EXPECT_NEAR(area, W * H, 1e-6 * W * H);
}

}  // namespace
}  // namespace zoomwarp

namespace zoomwarp {
namespace {

TEST(IcazBaselines, TraditionalLetterboxesThenCrops) {
  auto icaz = engine("pano_grossmugl_field_4to1.png", false);  // 2048 × 512
  warp::ViewRequest r;
  r.cx = 1024, r.cy = 256;
  r.zoom = 0;
  const auto v0 = icaz->traditional(r);
  EXPECT_NEAR(v0.geometry.screen_scale, 480.0 / 2048, 1e-12);  // the width fits
  double y0 = 1e9, y1 = -1e9;
  for (const auto& p : v0.screen) y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  EXPECT_NEAR(y1 - y0, 120, 1e-6);  // 512 × 480/2048: black bands above and below
  EXPECT_NEAR(y0, 120, 1e-6);
  r.zoom = 1, r.cx = 300, r.cy = 100;
  const auto v1 = icaz->traditional(r);
  for (std::size_t i = 0; i < v1.screen.size(); ++i) {  // a 1:1 crop, clamped at the left and top
    EXPECT_NEAR(v1.screen[i].x, v1.source.vertices[i].x - 60, 1e-9);
    EXPECT_NEAR(v1.screen[i].y, v1.source.vertices[i].y - 0, 1e-9);
  }
  EXPECT_TRUE(v1.centre_clamped);
}

}  // namespace
}  // namespace zoomwarp

namespace zoomwarp {
namespace {

TEST(IcazBadInput, NonFiniteOrOutOfRangeRequestsAreRefused) {
  auto icaz = engine("boats_lake_sunset.jpg", false);
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  warp::ViewRequest ok;
  ok.cx = 1000, ok.cy = 800;
  for (auto bad : std::vector<std::function<void(warp::ViewRequest&)>>{
           [&](auto& r) { r.zoom = nan; }, [&](auto& r) { r.cx = inf; }, [&](auto& r) { r.cy = nan; },
           [](auto& r) { r.screen_width = 0; }, [](auto& r) { r.screen_height = -5; },
           [](auto& r) { r.screen_width = 100000; }, [](auto& r) { r.max_screen_area = 0; }}) {
    warp::ViewRequest r = ok;
    bad(r);
    EXPECT_THROW(icaz->view(r), std::invalid_argument);
    EXPECT_THROW(icaz->traditional(r), std::invalid_argument);
  }
  // Out-of-range zoom and centres are clamped, not refused.
  warp::ViewRequest far = ok;
  far.zoom = 7, far.cx = -1e9, far.cy = 1e9;
  const auto v = icaz->view(far);
  EXPECT_NEAR(v.geometry.screen_scale, 1, 1e-9);
  EXPECT_TRUE(v.centre_clamped);
}

}  // namespace
}  // namespace zoomwarp
