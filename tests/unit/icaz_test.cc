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
#include <random>
#include <set>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/icaz/icaz.h"
#include "warp/icaz/shape_warp.h"
#include "warp/core/triangle_locator.h"
#include "warp/core/uniform_zoom.h"

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

// Where a source point lands under the piecewise-affine map `mesh` → `positions` (through the
// first triangle holding it), if any. Written here, not taken from warp::locate.
std::optional<Point> map_through(const warp::Mesh& mesh, const std::vector<Point>& positions, const Point& s) {
  for (const auto& t : mesh.triangles) {
    const Point &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    if (!inside(s, a, b, c)) continue;
    const double d = warp::signed_area2(a, b, c);
    const double l0 = warp::signed_area2(s, b, c) / d, l1 = warp::signed_area2(a, s, c) / d, l2 = 1 - l0 - l1;
    return Point{l0 * positions[t[0]].x + l1 * positions[t[1]].x + l2 * positions[t[2]].x,
                 l0 * positions[t[0]].y + l1 * positions[t[1]].y + l2 * positions[t[2]].y};
  }
  return std::nullopt;
}

// Screen position of a source point in a view, if any.
std::optional<Point> to_screen(const warp::View& v, const Point& s) { return map_through(v.source, v.screen, s); }

// The maximum triangle area on screen a view is refined to [ICAZ §5.3, §6.1]: the requested one,
// raised on large screens so that about IcazOptions::max_screen_triangles triangles cover them
// (icaz.h: max(max_screen_area, screen pixels / 4096)).
double effective_max_screen_area(const warp::ViewRequest& r) {
  return std::max(r.max_screen_area,
                  double(r.screen_width) * r.screen_height / warp::IcazOptions{}.max_screen_triangles);
}

// The largest area on screen (px²) of a triangle the view draws.
double largest_visible_area(const warp::View& v) {
  double largest = 0;
  for (int f : v.visible) {
    const auto& t = v.source.triangles[f];
    largest = std::max(largest, 0.5 * warp::signed_area2(v.screen[t[0]], v.screen[t[1]], v.screen[t[2]]));
  }
  return largest;
}

void check_view(const warp::Icaz& icaz, const warp::ViewRequest& r, const warp::View& v) {
  const double W = icaz.model().width, H = icaz.model().height;
  const auto& m = v.source;
  // No fold-overs, and the LOD cut is conforming: no T-junction, no hole.
  std::map<std::pair<int, int>, int> edges;
  for (const auto& t : m.triangles) {
    ASSERT_GT(warp::signed_area2(v.warped[t[0]], v.warped[t[1]], v.warped[t[2]]), 0) << "fold-over";
    for (int k = 0; k < 3; ++k) ++edges[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}];
  }
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
  // z = 1: the identity crop, exactly — the target is the image's size, where the warp's start
  // (the affine stretch) is already the optimum. Exactly up to the solve's rounding: with line
  // constraints a back-substitution leaves ~1e-9 px (1.06e-9 seen with 16-bit saliency maps, issue
  // 28), a millionth of what could change a rendered pixel (Views.ViewportAtZoomOneIsTheIiifCrop
  // compares the pixels themselves).
  if (r.zoom == 1 && W >= r.screen_width && H >= r.screen_height) {
    const double ox = std::clamp(r.cx - r.screen_width / 2.0, 0.0, W - r.screen_width);
    const double oy = std::clamp(r.cy - r.screen_height / 2.0, 0.0, H - r.screen_height);
    for (std::size_t i = 0; i < m.vertices.size(); ++i) {
      ASSERT_NEAR(v.screen[i].x, m.vertices[i].x - ox, 1e-6);
      ASSERT_NEAR(v.screen[i].y, m.vertices[i].y - oy, 1e-6);
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

// Continuity: a zoom step of 0.01 moves every visible point by little. Measured: 8.79 px (photo)
// and 8.61 px (4:1 panorama), most of it the geometric curve's magnification step at the screen's
// edge; the bound, 10 px, leaves ~1 px for the change of the warp itself to grow before it fails.
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
    EXPECT_LT(worst, 10.0) << file;
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

// The coarse warp a view's refinement is judged on, solved here as icaz.cc solves it (same mesh,
// weights, lines and tolerance; deterministic, so the same positions).
std::vector<Point> coarse_warp(const warp::ImageModel& m, const warp::ZoomGeometry& g) {
  const warp::ShapeWarp coarse(m.coarse.mesh, warp::triangle_weights(m.coarse.mesh, m.significance, m.w_min), m.width,
                               m.height, m.straight_lines);
  warp::WarpOptions options = warp::Icaz::solve_options(coarse, nullptr);
  options.tolerance = 0.05 / g.screen_scale;
  return coarse.solve(g.target_width, g.target_height, options).positions;
}

// A view's triangle f as the coarse warp places it (warped pixels): its corners through the
// affine map of the coarse triangle holding it.
std::array<Point, 3> coarse_placed(const warp::ImageModel& m, const std::vector<Point>& coarse, const warp::View& v,
                                   int f) {
  const auto& t = v.source.triangles[f];
  const Point &a = v.source.vertices[t[0]], &b = v.source.vertices[t[1]], &c = v.source.vertices[t[2]];
  const Point centroid{(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3};
  for (const auto& r : m.coarse.mesh.triangles) {
    const auto& corners = m.coarse.mesh.vertices;
    const Point &ra = corners[r[0]], &rb = corners[r[1]], &rc = corners[r[2]];
    if (!inside(centroid, ra, rb, rc)) continue;
    auto through = [&](const Point& p) {
      return warp::combine(warp::barycentric(p, ra, rb, rc), coarse[r[0]], coarse[r[1]], coarse[r[2]]);
    };
    return {through(a), through(b), through(c)};
  }
  ADD_FAILURE() << "a triangle outside the coarsest mesh";
  return {};
}

// The LOD cut's criterion [ICAZ §5.2–5.3]: the triangles in the viewing area are refined until
// none is larger on screen than the maximum triangle area — 500 px², or on large screens the
// effective threshold of icaz.h (screen pixels / 4096) — judged, as the paper does to break the
// chicken-and-egg of §5.2, on the coarse warp: where the coarse warp puts the viewing area and
// how large it makes each triangle. Checked for every drawn triangle the coarse warp puts in the
// viewing area, at every zoom of a sweep. What the viewer then sees is the fine warp, which
// enlarges significant parts beyond the coarse estimate and may move the viewing area: drawn
// triangles measured up to 1.03–1.31× the threshold on the photo and 1.7–2.7× on the 4:1
// panorama (360×640 at z = 0.2, where the fold-over guard reweighted the fine level); bounded
// at 3×, which still catches a cut that stops refining (a coarsest triangle is ~10 000 px²).
TEST(IcazScreenTriangles, NoneOnScreenAboveTheMaximumAreaAtAnyZoom) {
  constexpr double kFineWarpGrowth = 3;
  for (const char* file : {"boats_lake_sunset.jpg", "pano_grossmugl_field_4to1.png"}) {
    auto icaz = engine(file, true);
    const warp::ImageModel& m = icaz->model();
    for (auto [sw, sh] : {std::pair{480, 360}, std::pair{360, 640}, std::pair{3840, 2160}}) {
      double worst_coarse = 0, worst_drawn = 0;
      for (int step = 0; step <= 10; ++step) {
        warp::ViewRequest r;
        r.zoom = step / 10.0, r.cx = 0.4 * m.width, r.cy = 0.55 * m.height, r.screen_width = sw, r.screen_height = sh;
        const warp::View v = icaz->view(r);
        const warp::ZoomGeometry& g = v.geometry;
        const std::vector<Point> coarse = coarse_warp(m, g);
        // The viewing area on the coarse warp: centred on the view centre, inside the warped image
        // (centred where the image is smaller: letterboxing).
        const Point c = *map_through(m.coarse.mesh, coarse, {r.cx, r.cy});
        auto origin = [](double centre, double view, double target) {
          return view >= target ? (target - view) / 2 : std::clamp(centre - view / 2, 0.0, target - view);
        };
        const double x0 = origin(c.x, g.view_width, g.target_width), y0 = origin(c.y, g.view_height, g.target_height);
        const double threshold = effective_max_screen_area(r);
        double judged = 0;  // the largest, px²
        for (int f : v.visible) {
          const auto p = coarse_placed(m, coarse, v, f);
          const bool in_view =
              std::max({p[0].x, p[1].x, p[2].x}) > x0 && std::min({p[0].x, p[1].x, p[2].x}) < x0 + g.view_width &&
              std::max({p[0].y, p[1].y, p[2].y}) > y0 && std::min({p[0].y, p[1].y, p[2].y}) < y0 + g.view_height;
          if (in_view) judged = std::max(judged, 0.5 * warp::signed_area2(p[0], p[1], p[2]) * g.screen_scale * g.screen_scale);
        }
        EXPECT_LE(judged, threshold * (1 + 1e-6)) << file << " " << sw << "x" << sh << " z=" << r.zoom;
        worst_coarse = std::max(worst_coarse, judged / threshold);
        worst_drawn = std::max(worst_drawn, largest_visible_area(v) / threshold);
      }
      std::printf("[ figures ] %s %dx%d, z = 0..1: largest triangle on screen / threshold: %.3f under the coarse "
                  "warp, %.3f drawn\n", file, sw, sh, worst_coarse, worst_drawn);
      EXPECT_LE(worst_drawn, kFineWarpGrowth) << file << " " << sw << "x" << sh;
    }
  }
}

// Nested iteration [ICAZ §6.2]: the fine level starts from the coarse result, which is nearly its
// answer, so it needs fewer local–global iterations than the same solve from the affine stretch.
// The fine system is rebuilt here from the view — its mesh, and its forest nodes' mean
// significance mapped to [w_min, 1] by the range of the roots' means as icaz.cc does — and solved
// from the affine stretch; the whole refined mesh is solved (solve_margin ∞), so nothing is
// pinned. The paper reports a factor of two; Anderson acceleration makes even the affine start
// quick, so the saving here is 1–2 iterations: measured 4–7 against 5–8 per view, 43 against 57
// over this sweep.
TEST(IcazNestedIteration, TheFineLevelFromTheCoarseResultNeedsFewerIterations) {
  const auto shared = engine("boats_lake_sunset.jpg", false);
  warp::IcazOptions whole_mesh;
  whole_mesh.solve_margin = std::numeric_limits<double>::infinity();
  warp::Icaz icaz(shared->model(), whole_mesh);
  const warp::ImageModel& m = icaz.model();
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int root = 0; root < m.forest.root_count(); ++root)
    lo = std::min<double>(lo, m.node_mean[root]), hi = std::max<double>(hi, m.node_mean[root]);
  int nested_total = 0, affine_total = 0;
  for (auto [sw, sh] : {std::pair{480, 360}, std::pair{360, 640}})
    for (double z : {0.2, 0.4, 0.6, 0.8}) {
      warp::ViewRequest r;
      r.zoom = z, r.cx = 0.45 * m.width, r.cy = 0.5 * m.height, r.screen_width = sw, r.screen_height = sh;
      const warp::View v = icaz.view(r);
      ASSERT_GT(v.source.triangles.size(), m.coarse.mesh.triangles.size()) << "nothing refined at z=" << z;
      std::vector<double> weights;
      for (std::size_t f = 0; f < v.nodes.size(); ++f) {  // nodes past the stored forest: made lazily
        const auto& t = v.source.triangles[f];
        const double mean = std::size_t(v.nodes[f]) < m.node_mean.size()
                                ? m.node_mean[v.nodes[f]]
                                : warp::mean_over_triangle(m.significance, v.source.vertices[t[0]],
                                                           v.source.vertices[t[1]], v.source.vertices[t[2]]);
        weights.push_back(m.w_min + (1 - m.w_min) * std::clamp((mean - lo) / (hi - lo), 0.0, 1.0));
      }
      warp::WarpOptions options;  // as icaz.cc asks: 0.05 screen px
      options.tolerance = 0.05 / v.geometry.screen_scale;
      options.fixed_line_normals = true;
      const auto affine = warp::ShapeWarp(v.source, weights, m.width, m.height)
                              .solve(v.geometry.target_width, v.geometry.target_height, options);
      EXPECT_TRUE(v.fine_stats.converged && affine.converged);
      EXPECT_LT(v.fine_stats.iterations, affine.iterations) << sw << "x" << sh << " z=" << z;
      nested_total += v.fine_stats.iterations, affine_total += affine.iterations;
    }
  std::printf("[ figures ] fine level over 8 views: %d iterations from the coarse result, %d from the affine "
              "stretch\n", nested_total, affine_total);
}

// Nested iteration across zoom levels: a zoom action's coarse warp starts from the warps at the
// two anchor aspects around its target's (icaz.cc, coarse_start) instead of the affine stretch,
// and must end where the affine start does — here with no iteration at all: midway between
// these anchors one iteration moved their blend by at most 0.44 of half the tolerance, so the
// blend is taken as it is (icaz.cc, anchor_gap). With a maximum triangle area no coarsest
// triangle reaches nothing is refined, so a view's positions are its coarse warp: each is
// compared with the coarse warp solved here from the affine stretch to the same tolerance
// (0.05 screen px a step), at z = 0 on screens of five aspects (a fresh engine: every coarse
// warp is computed). Measured: within 0.026 screen px; 0 iterations against 70 from the affine
// stretch (1 per view before the blend was taken as it is).
TEST(IcazCoarseStart, AZoomActionStartsNearItsAnswerAndEndsWhereTheAffineStartDoes) {
  int anchored_total = 0, affine_total = 0;
  double worst = 0;
  for (const char* file : {"boats_lake_sunset.jpg", "interior_wine_djembe_tall.jpg"}) {
    warp::Icaz icaz(engine(file, false)->model());
    const warp::ImageModel& m = icaz.model();
    const warp::ShapeWarp coarse(m.coarse.mesh, warp::triangle_weights(m.coarse.mesh, m.significance, m.w_min), m.width,
                                 m.height, m.straight_lines);
    for (auto [sw, sh] : {std::pair{480, 360}, std::pair{360, 640}, std::pair{500, 500}, std::pair{800, 450},
                          std::pair{300, 600}}) {
      warp::ViewRequest r;
      r.zoom = 0, r.cx = 0.5 * m.width, r.cy = 0.5 * m.height, r.screen_width = sw, r.screen_height = sh;
      r.max_screen_area = 1e9;
      const warp::View v = icaz.view(r);
      ASSERT_EQ(v.source.vertices.size(), m.coarse.mesh.vertices.size()) << "refined";
      warp::WarpOptions options;
      options.tolerance = 0.05 / v.geometry.screen_scale;
      options.fixed_line_normals = true;
      const auto affine = coarse.solve(v.geometry.target_width, v.geometry.target_height, options);
      double moved = 0;  // screen px
      for (std::size_t i = 0; i < v.warped.size(); ++i) {
        const Point& a = affine.positions[v.forest_vertex[i]];  // the forest's first vertices are the coarsest mesh's
        moved = std::max(moved, std::hypot(v.warped[i].x - a.x, v.warped[i].y - a.y) * v.geometry.screen_scale);
      }
      EXPECT_LT(moved, 0.1) << file << " " << sw << "x" << sh;
      EXPECT_TRUE(v.coarse_stats.converged);
      EXPECT_EQ(v.coarse_stats.iterations, 0) << file << " " << sw << "x" << sh << ": the blend not taken as it is";
      worst = std::max(worst, moved);
      anchored_total += v.coarse_stats.iterations, affine_total += affine.iterations;
    }
  }
  std::printf("[ figures ] coarse warps at z = 0 on 10 screens: %d iterations from the anchors, %d from the affine "
              "stretch; largest difference %.3f screen px\n", anchored_total, affine_total, worst);
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

// The zoom evolution [ICAZ §5.1]: the target aspect ratio and the size of the viewing area are
// interpolated between their extremes — aspect from the screen's (z = 0) to the image's (z = 1),
// viewing-area width from the whole z = 0 warped image to the screen — and the warped image keeps
// the source's area. The paper's curve is linear in both; the geometric one (our default) makes
// the viewing-area width w0·(sw/w0)^z. Interior points are checked against these formulas,
// written out here, where an interpolation gone wrong shows and the ends would not; the image is
// large enough that the viewing area fits the warped image there (no clamp applies).
TEST(IcazZoomCurve, InteriorPointsFollowThePapersInterpolation) {
  const double W = 5400, H = 2500, sw = 480, sh = 360;
  const double w0 = std::sqrt(W * H * sw / sh);  // the z = 0 warped image's width
  for (double z : {0.25, 0.5, 0.75}) {
    SCOPED_TRACE("z=" + std::to_string(z));
    const double aspect = (1 - z) * sw / sh + z * W / H;
    const double linear_w = (1 - z) * w0 + z * sw, geometric_w = w0 * std::pow(sw / w0, z);
    for (auto [curve, view_w] :
         {std::pair{warp::ZoomCurve::kLinear, linear_w}, std::pair{warp::ZoomCurve::kGeometric, geometric_w}}) {
      const auto g = warp::zoom_geometry(W, H, sw, sh, z, curve);
      EXPECT_NEAR(g.target_width, std::sqrt(W * H * aspect), 1e-6);
      EXPECT_NEAR(g.target_height, std::sqrt(W * H / aspect), 1e-6);
      EXPECT_NEAR(g.view_width, view_w, 1e-6);
      EXPECT_NEAR(g.view_height, view_w * sh / sw, 1e-6);
      EXPECT_NEAR(g.screen_scale, sw / view_w, 1e-12);
    }
  }
  // The ends: the screen's aspect and the whole warped image at z = 0, the image 1:1 at z = 1.
  const auto g0 = warp::zoom_geometry(W, H, sw, sh, 0, warp::ZoomCurve::kLinear);
  EXPECT_NEAR(g0.target_width, w0, 1e-6);
  EXPECT_NEAR(g0.view_width, w0, 1e-6);
  const auto g1 = warp::zoom_geometry(W, H, sw, sh, 1, warp::ZoomCurve::kLinear);
  EXPECT_NEAR(g1.target_width, W, 1e-6);
  EXPECT_NEAR(g1.target_height, H, 1e-6);
  EXPECT_NEAR(g1.screen_scale, 1, 1e-12);
}


// Two views of the boats photo (with its lines) at zoom 0.3 and `to_zoom`, centred apart, and the
// geomorph between them [ICAZ §5.3].
struct GeomorphCase {
  std::shared_ptr<warp::Icaz> icaz;
  warp::View from, to;
  warp::Geomorph geomorph;
};
GeomorphCase geomorph_case(double to_zoom) {
  GeomorphCase c;
  c.icaz = engine("boats_lake_sunset.jpg", true);
  const double W = c.icaz->model().width, H = c.icaz->model().height;
  warp::ViewRequest a, b;
  a.zoom = 0.3, a.cx = 0.3 * W, a.cy = 0.6 * H;
  b.zoom = to_zoom, b.cx = 0.7 * W, b.cy = 0.4 * H;
  c.from = c.icaz->view(a), c.to = c.icaz->view(b);
  c.geomorph = c.icaz->geomorph(c.from, c.to);
  return c;
}

// Geomorphing [ICAZ §5.3]: the common refinement of two views' cuts holds every vertex of both,
// and its two position sets draw each view exactly — a grid of source points lands through the
// geomorph's mesh where it lands in that view, both located here through each mesh's own
// triangles — with neither end folded. So a client interpolating from one to the other starts
// and ends on the views themselves, without a pop.
TEST(IcazGeomorph, EachEndDrawsItsViewExactly) {
  const GeomorphCase c = geomorph_case(0.7);
  const double W = c.icaz->model().width, H = c.icaz->model().height;
  const warp::View &va = c.from, &vb = c.to;
  const warp::Geomorph& g = c.geomorph;
  std::set<int> common(g.forest_vertex.begin(), g.forest_vertex.end());
  for (const auto* v : {&va, &vb})
    for (int f : v->forest_vertex) ASSERT_TRUE(common.count(f)) << "a view's vertex is missing from the common refinement";
  EXPECT_GT(g.source.vertices.size(), std::max(va.source.vertices.size(), vb.source.vertices.size()));
  double worst = 0;
  for (int gy = 0; gy <= 16; ++gy)
    for (int gx = 0; gx <= 24; ++gx) {
      const Point s{W * (gx + 0.37) / 25, H * (gy + 0.61) / 17};  // off the forest's bisection lines
      for (const auto& [view, ends] : {std::pair{&va, &g.from}, std::pair{&vb, &g.to}}) {
        const auto expected = to_screen(*view, s), drawn = map_through(g.source, *ends, s);
        ASSERT_TRUE(expected && drawn);
        worst = std::max(worst, std::hypot(drawn->x - expected->x, drawn->y - expected->y));
      }
    }
  EXPECT_LT(worst, 1e-6) << "a geomorph end does not draw its view";
  for (const auto& t : g.source.triangles) {
    EXPECT_GT(warp::signed_area2(g.from[t[0]], g.from[t[1]], g.from[t[2]]), 0);
    EXPECT_GT(warp::signed_area2(g.to[t[0]], g.to[t[1]], g.to[t[2]]), 0);
  }
}


// Geomorphing places each vertex a view lacks through the view's triangle holding it, found by a
// grid (TriangleLocator) instead of a scan over all triangles: on real meshes — two views' cuts,
// their common refinement, the coarsest mesh — the grid answers exactly what the scan
// (locate_in) answers, triangle and barycentric coordinates bit for bit, for every vertex, points
// on every edge (its midpoint and a quarter along), points inside, and points on and just
// outside the image's border.
TEST(IcazGeomorph, TheGridLocatesWhatTheScanLocates) {
  const GeomorphCase c = geomorph_case(0.8);
  const auto& icaz = c.icaz;
  const double W = icaz->model().width, H = icaz->model().height;
  const warp::View &va = c.from, &vb = c.to;
  const warp::Geomorph& g = c.geomorph;
  std::mt19937 rng(11);
  int points = 0;
  for (const warp::Mesh* mesh : {&va.source, &vb.source, &g.source, &icaz->model().coarse.mesh}) {
    std::vector<Point> probes = mesh->vertices;
    for (const auto& t : mesh->triangles)
      for (int k = 0; k < 3; ++k) {
        const Point &p = mesh->vertices[t[k]], &q = mesh->vertices[t[(k + 1) % 3]];
        probes.push_back({(p.x + q.x) / 2, (p.y + q.y) / 2});
        probes.push_back({0.75 * p.x + 0.25 * q.x, 0.75 * p.y + 0.25 * q.y});
      }
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 2000; ++i) probes.push_back({u(rng) * W, u(rng) * H});
    for (double off : {0.0, 1e-12, 1e-9, 1e-6, 0.5}) {
      for (int i = 0; i <= 50; ++i) {
        const double x = W * i / 50, y = H * i / 50;
        probes.insert(probes.end(), {{x, -off}, {x, H + off}, {-off, y}, {W + off, y}});
      }
    }
    const warp::TriangleLocator grid(*mesh);
    for (const Point& p : probes) {
      const warp::MeshPoint found = grid.find(p), scanned = warp::locate_in(*mesh, p);
      ASSERT_EQ(found.triangle, scanned.triangle) << "(" << p.x << ", " << p.y << ")";
      for (int k = 0; k < 3; ++k) ASSERT_EQ(found.barycentric[k], scanned.barycentric[k]) << "(" << p.x << ", " << p.y << ")";
    }
    points += int(probes.size());
  }
  std::printf("[ figures ] grid and scan agree on %d points of 4 meshes\n", points);
}

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
