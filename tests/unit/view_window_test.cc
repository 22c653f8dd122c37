// fit= (issue 41), warp/window/view_window.h: the window's invariants on plain maps — a region the
// curator marked important is never cropped while less important content could be instead; the
// budget decides how much is cropped; the window follows the request's centre and is continuous
// in zoom — and, through the ICAZ operator on a real photograph, what a user sees: the important
// region whole on the screen at zoom 0, no fold-over, and at zoom 1 the exact crop around the
// centre asked for.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/core/uniform_zoom.h"
#include "warp/icaz/icaz.h"
#include "warp/window/view_window.h"

namespace zoomwarp {
namespace {

using warp::Fit;
using warp::FitOptions;
using warp::Point;
using warp::SignificanceEdit;
using warp::SignificanceMap;
using warp::ViewRequest;

// A W × H image's map, `side` map pixels on its long side, of constant value `base`.
SignificanceMap flat_map(double W, double H, float base, int side = 200) {
  SignificanceMap m;
  m.scale = side / std::max(W, H);
  m.width = std::max(1, int(std::lround(W * m.scale))), m.height = std::max(1, int(std::lround(H * m.scale)));
  m.values.assign(std::size_t(m.width) * m.height, base);
  return m;
}

// Paints image-pixel rectangle [x0, x1) × [y0, y1) with `value`.
void paint(SignificanceMap& m, double x0, double y0, double x1, double y1, float value) {
  warp::paint_polygon(m, {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, value);
}

SignificanceEdit region(double x0, double y0, double x1, double y1, float weight) {
  return {{{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, weight};
}

ViewRequest request(double W, double H, int sw, int sh, double zoom = 0) {
  ViewRequest r;
  r.zoom = zoom, r.cx = W / 2, r.cy = H / 2, r.screen_width = sw, r.screen_height = sh;
  return r;
}

TEST(ViewWindow, TheBudgetDecidesWhatIsCroppedAndAnAspectChangeWithinItIsWarpedWhole) {
  const double W = 3000, H = 1000;  // 3:1 on a 9:16 phone: an aspect change of 5.33
  const auto p = warp::significance_profile(flat_map(W, H, 0.5f), {}, W, H);
  const ViewRequest r = request(W, H, 360, 640);
  const ViewRequest framed = warp::framed_view(r, {Fit::kAuto, 1.5}, p);
  EXPECT_TRUE(framed.frame.cover);
  EXPECT_NEAR(framed.frame.aspect, 3.0 / 1.5, 1e-12);  // the warp keeps 1.5 of the change
  const warp::ViewWindow w = warp::window_frame(p, {Fit::kAuto, 1.5}, 360, 640).window;
  EXPECT_TRUE(w.crops && w.along_x);
  EXPECT_NEAR(w.length, W * (360.0 / 640) / 2.0, 1e-9);
  // A flat map: the middle window, so the centre does not move.
  EXPECT_NEAR(framed.cx, W / 2, 1e-9);
  // A budget the change fits in: warped whole, as fit=warp.
  const ViewRequest whole = warp::framed_view(r, {Fit::kAuto, 6}, p);
  EXPECT_FALSE(whole.frame.cover);
  EXPECT_EQ(whole.frame.aspect, 0);
  EXPECT_EQ(whole.cx, r.cx);
  // fit=warp and fit=pad leave the request as it was; crop takes the image's aspect.
  for (Fit f : {Fit::kWarp, Fit::kPad}) {
    const ViewRequest same = warp::framed_view(r, {f, 1.5}, p);
    EXPECT_FALSE(same.frame.cover);
    EXPECT_EQ(same.frame.aspect, 0);
  }
  const ViewRequest crop = warp::framed_view(r, {Fit::kCrop, 1.5}, p);
  EXPECT_TRUE(crop.frame.cover);
  EXPECT_DOUBLE_EQ(crop.frame.aspect, 3.0);
  // A method that does not warp (traditional zoom) shows the whole image for auto, as before.
  EXPECT_FALSE(warp::framed_view(r, {Fit::kAuto, 1.5}, p, false).frame.cover);
  EXPECT_TRUE(warp::framed_view(r, {Fit::kCrop, 1.5}, p, false).frame.cover);
}

TEST(ViewWindow, TallImagesAreCroppedAlongY) {
  const double W = 1000, H = 4000;
  SignificanceMap m = flat_map(W, H, 0.1f);
  paint(m, 0, 3000, W, 3600, 1.0f);  // what matters is low in the picture
  const auto p = warp::significance_profile(m, {}, W, H);
  const warp::ViewWindow w = warp::window_frame(p, {Fit::kAuto, 1.5}, 640, 360).window;
  ASSERT_TRUE(w.crops);
  EXPECT_FALSE(w.along_x);
  EXPECT_LE(w.start, 3000 + 1);
  EXPECT_GE(w.start + w.length, 3600 - 1);
  const ViewRequest framed = warp::framed_view(request(W, H, 640, 360), {Fit::kAuto, 1.5}, p);
  EXPECT_EQ(framed.cx, W / 2);
  EXPECT_NEAR(framed.cy, w.start + w.length / 2, 1e-9);
}

TEST(ViewWindow, CuratorImportantContentIsNeverCroppedWhileLessImportantExists) {
  const double W = 4000, H = 1000;
  SignificanceMap m = flat_map(W, H, 0.2f);
  paint(m, 3000, 0, 4000, 1000, 1.0f);  // the detector's favourite: bright detail on the right
  // The curator marks a plain stretch on the left important (painted into the map at weight 1,
  // as an edit is).
  const SignificanceEdit important = region(100, 300, 550, 700, 1.0f);
  paint(m, 100, 300, 550, 700, 1.0f);
  const auto p = warp::significance_profile(m, {important}, W, H);
  for (const FitOptions fit : {FitOptions{Fit::kAuto, 1.5}, FitOptions{Fit::kAuto, 1.0}, FitOptions{Fit::kCrop, 1.5}}) {
    const warp::ViewWindow w = warp::window_frame(p, fit, 360, 640).window;
    ASSERT_TRUE(w.crops);
    ASSERT_GE(w.length, 450);
    EXPECT_LE(w.start, 100 + 1e-6) << warp::fit_name(fit.fit) << " " << fit.max_distortion;
    EXPECT_GE(w.start + w.length, 550 - 1e-6);
  }
  // Without the curator's region the window goes to the detail on the right.
  const warp::ViewWindow w = warp::window_frame(warp::significance_profile(m, {}, W, H), {Fit::kCrop, 1.5}, 360, 640).window;
  EXPECT_GE(w.start + w.length / 2, 3000) << "the window's middle on the detail";
  // A region marked less important (weight 0) is never preferred: the window avoids it.
  SignificanceMap dull = flat_map(W, H, 0.5f);
  paint(dull, 0, 0, 2000, 1000, 0.0f);
  const warp::ViewWindow right =
      warp::window_frame(warp::significance_profile(dull, {region(0, 0, 2000, 1000, 0.0f)}, W, H), {Fit::kCrop, 1.5}, 360, 640).window;
  EXPECT_GE(right.start, 2000 - 1e-6);
}

// What matters is kept whole rather than cut at the screen's edge: a bright object a little
// narrower than the window, beside a long textured band of more total significance, is shown
// whole (the plain sum would take the band and cut the object, as it cut the fig on its plate).
TEST(ViewWindow, AnObjectIsKeptWholeRatherThanCutAtTheEdge) {
  const double W = 4000, H = 1000;
  SignificanceMap m = flat_map(W, H, 0.05f);
  paint(m, 2400, 0, 2800, 1000, 1.0f);  // the object, 400 px
  paint(m, 1200, 0, 2400, 1000, 0.4f);  // the band on its left, 1200 px
  const warp::ViewWindow w = warp::window_frame(warp::significance_profile(m, {}, W, H), {Fit::kCrop, 1.5}, 360, 640).window;
  ASSERT_NEAR(w.length, 562.5, 1e-9);
  EXPECT_LE(w.start, 2400 - 0.1 * w.length + 1e-6) << "the object's left end clear of the edge zone";
  EXPECT_GE(w.start + w.length, 2800 + 0.1 * w.length - 1e-6) << "its right end too";
}

TEST(ViewWindow, AnImportantRegionWiderThanTheWindowFillsIt) {
  const double W = 4000, H = 1000;
  SignificanceMap m = flat_map(W, H, 0.9f);
  const SignificanceEdit important = region(1000, 0, 3000, 1000, 1.0f);
  paint(m, 1000, 0, 3000, 1000, 1.0f);
  const warp::ViewWindow w = warp::window_frame(warp::significance_profile(m, {important}, W, H), {Fit::kCrop, 1.5}, 360, 640).window;
  ASSERT_TRUE(w.crops);
  EXPECT_GE(w.start, 1000 - 1e-6);
  EXPECT_LE(w.start + w.length, 3000 + 1e-6);
}

TEST(ViewWindow, FollowsTheRequestCentreAndIsContinuousInZoom) {
  const double W = 3000, H = 1000;
  SignificanceMap m = flat_map(W, H, 0.1f);
  paint(m, 200, 0, 900, 1000, 1.0f);
  const auto p = warp::significance_profile(m, {}, W, H);
  const FitOptions fit{Fit::kAuto, 1.5};
  const ViewRequest centred = warp::framed_view(request(W, H, 360, 640), fit, p);
  EXPECT_LT(centred.cx, 1000);  // moved to what matters
  // Panning the overview moves the window by as much.
  ViewRequest panned = request(W, H, 360, 640);
  panned.cx += 250;
  EXPECT_NEAR(warp::framed_view(panned, fit, p).cx, centred.cx + 250, 1e-9);
  // The offset fades with the zoom, and the frame's aspect stays: continuous, and at zoom 1 the
  // view centres where the request asks.
  double last = centred.cx;
  for (int k = 1; k <= 1000; ++k) {
    const ViewRequest v = warp::framed_view(request(W, H, 360, 640, k / 1000.0), fit, p);
    EXPECT_LE(std::abs(v.cx - last), 2.0) << "zoom " << k / 1000.0;
    EXPECT_EQ(v.frame.aspect, centred.frame.aspect);
    last = v.cx;
  }
  EXPECT_EQ(last, W / 2);
}

// fit=auto fitted to a method's warp (budgeted_frame): the widest frame whose measured salient
// squeeze keeps the budget. A 3:1 image on a 9:16 phone (a change of 5.33), budget 1.4; the
// "method" squeezes what matters by a share k of the frame's allowance (the uniform stretch its
// target keeps): k < 1 a content-aware warp with room to spare, k > 1 one that squeezes what
// matters more than the stretch (mp before issue 41), k tiny a warp that never squeezes it.
TEST(ViewWindow, TheBudgetIsHeldOnWhatTheMethodsWarpDoes) {
  const double W = 3000, H = 1000, budget = 1.4;
  const FitOptions fit{Fit::kAuto, budget};
  const auto allowance = [&](const warp::WindowFrame& f) {
    return f.window.crops ? (W / H) / f.frame.aspect : (W / H) / (360.0 / 640);
  };
  for (double k : {0.5, 0.8, 1.0, 1.3, 1.0 / 64}) {
    int views = 0;
    const warp::WindowFrame f = warp::budgeted_frame(W, H, fit, 360, 640, [&](const warp::WindowFrame& c) {
      ++views;
      const double a = allowance(c) * (1 - 1e-12);  // the allowance back from a₀, rounding aside
      return warp::SalientSqueezeMeasure{std::max(1.0, k * a), std::max(1.0, 1.1 * k * a)};
    });
    SCOPED_TRACE(k);
    EXPECT_LE(views, warp::kBudgetBisections + 2);
    const double a = allowance(f);
    // Held: the squeeze within the budget at p90 and at p99 (4/3 of it).
    EXPECT_LE(k * a, budget + 1e-9);
    EXPECT_LE(1.1 * k * a, warp::kSqueezeP99OverBudget * budget + 1e-9);
    if (k * (W / H) / (360.0 / 640) <= budget) {  // the whole change holds: nothing cropped, as fit=warp
      EXPECT_FALSE(f.window.crops);
      continue;
    }
    ASSERT_TRUE(f.window.crops);
    EXPECT_TRUE(f.frame.cover);
    EXPECT_NEAR(f.window.length, W * (360.0 / 640) / f.frame.aspect, 1e-9);
    // The widest that holds (budget / k), to the bisection's resolution: two halvings in log of
    // [budget, change] when the budget's frame holds, of [1, budget] when it does not.
    const double change = (W / H) / (360.0 / 640), bound = std::min(budget / k, change);
    EXPECT_GE(a, bound / std::pow(k <= 1 ? change / budget : budget, 0.25) - 1e-9);
    if (k <= 1) EXPECT_GE(a, budget - 1e-9) << "never narrower than the budget's own frame when that holds";
    else EXPECT_LT(a, budget) << "narrower than the budget's own frame: the method squeezes more than the stretch";
  }
  // Other fits are window_frame's, measured never.
  for (Fit other : {Fit::kWarp, Fit::kCrop, Fit::kPad}) {
    const warp::WindowFrame f = warp::budgeted_frame(W, H, {other, budget}, 360, 640, [](const warp::WindowFrame&) {
      ADD_FAILURE() << "measured";
      return warp::SalientSqueezeMeasure{};
    });
    EXPECT_EQ(f.frame.aspect, warp::window_frame(W, H, {other, budget}, 360, 640).frame.aspect);
  }
  // A change within the budget (3:1 on 8:3, 1.125): warped whole when the warp holds it, after
  // one view; cropped a little when the method squeezes what matters past the budget even so.
  int views = 0;
  EXPECT_FALSE(warp::budgeted_frame(W, H, fit, 640, 240, [&](const warp::WindowFrame& c) {
                 ++views;
                 EXPECT_FALSE(c.window.crops);
                 return warp::SalientSqueezeMeasure{1.2, 1.3};
               }).window.crops);
  EXPECT_EQ(views, 1);
  const warp::WindowFrame tight = warp::budgeted_frame(W, H, fit, 640, 240, [&](const warp::WindowFrame& c) {
    const double a = c.window.crops ? (W / H) / c.frame.aspect : 1.125;
    return warp::SalientSqueezeMeasure{1.35 * a, 1.35 * a};
  });
  ASSERT_TRUE(tight.window.crops);
  EXPECT_LT((W / H) / tight.frame.aspect, 1.4 / 1.35);
  // The same aspect: nothing to fit, nothing measured.
  EXPECT_FALSE(warp::budgeted_frame(W, H, fit, 600, 200, [](const warp::WindowFrame&) {
                 ADD_FAILURE() << "measured";
                 return warp::SalientSqueezeMeasure{};
               }).window.crops);
}

TEST(ViewWindow, DegenerateImagesAndBudgetsAreAnsweredOrRefused) {
  // 1×1, a 1×10 000 sliver both ways, an empty map: no crash, a window inside the image.
  for (const auto& [W, H] : {std::pair{1.0, 1.0}, std::pair{1.0, 10000.0}, std::pair{10000.0, 1.0}}) {
    const auto p = warp::significance_profile(flat_map(W, H, 0.0f), {}, W, H);
    for (const auto& [sw, sh] : {std::pair{16, 4096}, std::pair{4096, 16}, std::pair{360, 640}}) {
      const ViewRequest v = warp::framed_view(request(W, H, sw, sh), {Fit::kAuto, 1.5}, p);
      EXPECT_TRUE(v.cx >= 0 && v.cx <= W && v.cy >= 0 && v.cy <= H) << W << "x" << H << " on " << sw << "x" << sh;
      const warp::ViewWindow w = warp::window_frame(p, {Fit::kCrop, 1.5}, sw, sh).window;
      EXPECT_GE(w.start, 0);
      EXPECT_LE(w.start + w.length, std::max(W, H) + 1e-9);
    }
  }
  const warp::SignificanceProfile empty = warp::significance_profile({}, {}, 100, 100);
  EXPECT_NO_THROW(warp::framed_view(request(100, 100, 360, 640), {Fit::kAuto, 1.5}, empty));
  for (double bad : {0.5, 0.0, 8.5, std::nan(""), double(INFINITY)})
    EXPECT_THROW(warp::framed_view(request(100, 100, 360, 640), {Fit::kAuto, bad}, empty), std::invalid_argument) << bad;
}

// Through the ICAZ operator on the bundled boats (2560×1600 on a 9:16 phone, a change of 2.84):
// the curator's region whole on the screen at zoom 0, nothing folded; at zoom 1 the exact crop.
TEST(ViewWindow, IcazViewsShowTheImportantRegionAndEndInTheExactCrop) {
  const tiles::Raster full = testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg");
  const tiles::Raster small = testing::resize(full, 1024, 640);
  const double W = full.width, H = full.height;
  warp::ImageModel model = warp::make_image_model(small, W, H);
  const SignificanceEdit important = region(150, 500, 450, 900, 1.0f);  // far left, where little is
  warp::add_significance_edits(model, {important});
  warp::Icaz icaz(std::move(model));
  const FitOptions fit{Fit::kAuto, warp::kDefaultMaxDistortion};
  const warp::SignificanceProfile& profile = icaz.significance_profile();
  // As api/framed_views.h frames it: the window, then its offset through the warp at zoom 0.
  const warp::WindowFrame wf = warp::window_frame(profile, fit, 360, 640);
  ASSERT_TRUE(wf.frame.cover && wf.window.crops);
  EXPECT_LE(wf.window.start, 150);
  EXPECT_GE(wf.window.start + wf.window.length, 450);
  const double offset = warp::warped_window_offset(
      icaz.view(warp::panned_view(request(W, H, 360, 640), wf, warp::window_offset(wf.window, profile), profile.width, profile.height)), wf.window,
      profile);
  const warp::View v = icaz.view(warp::panned_view(request(W, H, 360, 640), wf, offset, profile.width, profile.height));
  for (const Point& corner : important.polygon) {
    const Point s = warp::locate(v.source, v.screen, corner);
    EXPECT_TRUE(s.x >= 0 && s.x <= 360 && s.y >= 0 && s.y <= 640) << corner.x << "," << corner.y << " -> " << s.x << "," << s.y;
  }
  for (int f : v.visible) {
    const auto& t = v.source.triangles[f];
    EXPECT_GT(warp::signed_area2(v.screen[t[0]], v.screen[t[1]], v.screen[t[2]]), 0) << "fold at triangle " << f;
  }
  // Zoom 1: source pixel (x, y) is screen pixel (x − cx + 180, y − cy + 320), to the 0.05 px.
  ViewRequest one = request(W, H, 360, 640, 1);
  one.cx = 1000, one.cy = 700;
  const warp::View z1 = icaz.view(warp::panned_view(one, wf, offset, profile.width, profile.height));
  for (int f : z1.visible)
    for (int k : z1.source.triangles[f]) {
      EXPECT_NEAR(z1.screen[k].x, z1.source.vertices[k].x - 1000 + 180, 0.05);
      EXPECT_NEAR(z1.screen[k].y, z1.source.vertices[k].y - 700 + 320, 0.05);
    }
}

}  // namespace
}  // namespace zoomwarp
