// The viewing window of `fit=auto` and `fit=crop` (fit.h, issue 41): which part of the image a
// view at zoom 0 crops to, chosen once for every method. Every method maps the whole image onto a
// target of the request's ZoomFrame aspect and shows the screen-shaped part of it around the
// request's centre (core/zoom_curve.h, core/uniform_zoom.h); this part sets that aspect and moves
// the centre so that what is cropped is what matters least:
//
//   the target aspect a₀ keeps at most `max_distortion` of the aspect change: for an image wider
//   than the screen (a_I = W/H > a_S = w/h by more than the budget B) a₀ = a_I / B, so the screen
//   shows a source window about L = W·a_S/a₀ wide (taller images alike, along y);
//
//   the window is the L-long interval along that axis with the most curator-important area (the
//   curator's regions of weight ≥ kImportantWeight), and among those the most significance,
//   weighed down towards its edges (from 1 to −1 over the outer tenth of each side, so that what
//   matters is kept whole rather than cut at the screen's edge) — so a region the curator marked
//   important is never cropped while less important content could be instead, and faces (painted
//   fully significant) weigh as much as anything;
//
//   the request's centre c pans it: the view centres on c + d·(1 − z), d the best window's offset
//   from the image centre, so a request centred on the image (every client's default) shows the
//   best window, a pan of the overview moves it by as much, and the offset fades out as the
//   zoom goes to 1, where the view is the exact crop around c. Continuous in z and in c.
//
// Plain functions on plain data; thread-safe.
#pragma once

#include <functional>
#include <vector>

#include "warp/core/view.h"
#include "warp/saliency/significance.h"
#include "warp/window/fit.h"

namespace zoomwarp::warp {

// A curator's region counts as marked important from this weight on (SignificanceEdit::weight ∈
// [0, 1]; 1 = "most important", the viewer's default for "important").
inline constexpr float kImportantWeight = 0.5f;

// Where an image's significance lies along each axis, at the map's resolution: per map column
// (row) the sum of its significance, and the number of its pixels inside a region the curator
// marked important. Made once per engine (warp/icaz/icaz.h keeps one per version and saliency).
struct SignificanceProfile {
  double width = 0, height = 0;  // the image, px
  std::vector<double> column_mass, row_mass;
  std::vector<double> column_important, row_important;
};

SignificanceProfile significance_profile(const SignificanceMap& map, const std::vector<SignificanceEdit>& edits,
                                         double width, double height);

// What zoom 0 shows along the axis the screen crops: the source interval [start, start + length)
// (image px). `crops` false: nothing is cropped (the whole image is shown, warped or not).
struct ViewWindow {
  bool crops = false;
  bool along_x = true;
  double start = 0, length = 0;
};

// The frame every view of a fit gets, and its best window before any pan.
struct WindowFrame {
  ZoomFrame frame;  // the default (the screen's aspect, whole) when nothing is cropped
  ViewWindow window;
};

// The frame of `fit` for a screen on a W × H image, and the length and axis of its window (start
// 0 until place_window): what needs no significance, so that a caller can start the method's warp
// for the frame before the map is at hand. `warps` is false for a method that does not warp
// (traditional zoom): auto and warp then show the whole image as before, crop covers the screen.
// crop and pad set the frame for traditional zoom, which draws them whatever the method
// (fit_warps). Throws std::invalid_argument for a max_distortion outside
// [kMinMaxDistortion, kMaxMaxDistortion] or not finite.
WindowFrame window_frame(double width, double height, const FitOptions& fit, int screen_width, int screen_height,
                         bool warps = true);

// fit=auto fitted to a method's warp (issue 41): the window_frame above assumes the warp squeezes
// everything as a uniform stretch of `max_distortion` would; a content-aware warp squeezes what
// matters less than that where the image has room elsewhere, and mp can squeeze it more. So
// the budget is held on what the method does: the frame is the widest (the largest allowance,
// the uniform stretch its target keeps, from 1 — a plain crop — up to the whole aspect change)
// whose zoom-0 view keeps the salient anisotropy (the view's own significance, top fifth) at
// p90 ≤ max_distortion and p99 ≤ kSqueezeP99OverBudget × it, as `squeeze` measures it for a
// frame (its window still to be placed). A change within the budget: the whole image if its warp
// holds (as window_frame), else cropped; beyond it, the budget's own frame first and, if it
// holds, the whole change; then kBudgetBisections halvings of the interval (in log) between what
// holds and what does not — at most kBudgetBisections + 2 views per call. Monotone enough in
// practice: a wider frame squeezes more. Frames of other fits are window_frame's.
struct SalientSqueezeMeasure {
  double p90 = 1, p99 = 1;
};
using SalientSqueeze = std::function<SalientSqueezeMeasure(const WindowFrame&)>;
inline constexpr double kSqueezeP99OverBudget = 4.0 / 3;  // issue 41: p99 2.0 beside p90 1.5
inline constexpr int kBudgetBisections = 2;
WindowFrame budgeted_frame(double width, double height, const FitOptions& fit, int screen_width, int screen_height,
                           const SalientSqueeze& squeeze);

// Places a cropping window on the profile's image: the start of the most important, then most
// significant, interval of its length (nothing for a window that does not crop).
void place_window(ViewWindow& window, const SignificanceProfile& profile);

// window_frame then place_window.
WindowFrame window_frame(const SignificanceProfile& profile, const FitOptions& fit, int screen_width, int screen_height,
                         bool warps = true);

// The best window's offset from the image centre along its axis (image px): where a request
// centred on the image moves to, for a method that does not warp.
double window_offset(const ViewWindow& window, const SignificanceProfile& profile);

// The same for a warp: the warp enlarges what matters, so the source window does not fill the
// screen as it did in the source. From `zoom0`, a method's view at zoom 0 of a request with the
// window's frame (any centre), the window is chosen again where the method draws it — the
// screen-wide stretch of the warped image with the most important area (a margin of 2 % inside
// its edges), then the most significance, the profile's bins placed through the warp along the
// image's middle line — and the offset is that of the source point landing in its middle.
double warped_window_offset(const View& zoom0, const ViewWindow& window, const SignificanceProfile& profile);

// The request a method draws: `f`'s frame, and the centre moved by `offset` along the window's
// axis, fading out with the zoom (c + offset·(1 − z), clamped to the width × height image).
ViewRequest panned_view(const ViewRequest& request, const WindowFrame& f, double offset, double width, double height);

// window_frame, then panned_view by window_offset: the request framed without a method's warp
// (the api refines the offset through the method's warp, api/framed_views.h).
ViewRequest framed_view(const ViewRequest& request, const FitOptions& fit, const SignificanceProfile& profile,
                        bool warps = true);

}  // namespace zoomwarp::warp
