// One metric set for every retargeting method (docs/compare.md), computed from what a method
// answers a request with — its View, or for a method without a mesh (seam carving) its rendered
// screen — with traditional zoom at the same (zoom, view centre, screen) as the reference:
//
//   scale gain      on-screen area of the salient region (the top tenth of the significance
//                   map's pixels) divided by its on-screen area under traditional zoom
//                   [ICAZ §6.1: "salient objects are shown larger"]; 1 = no gain;
//   anisotropy      σ1/σ2 of each triangle's affine map (source → screen), averaged with the
//                   triangle's on-screen salient source area as weight ("salient"), and with its
//                   on-screen significance mass as weight ("weighted"); 1 = shapes kept, a uniform
//                   stretch of the image onto the screen gives (W/H)/(w/h) or its inverse;
//   straightness    per line (the curator's), the largest distance of its warped samples on
//                   screen from the chord through its first and last sample on screen, screen px;
//                   the worst line is reported [ICAZ §4.3];
//   folds           emitted (visible) triangles with signed screen area ≤ 0; must be 0;
//   coverage        share of screen pixels (centres) covered by the visible triangles; 1 for every
//                   retargeting method at every zoom (traditional zoom letterboxes).
//
// Only what is on screen counts: a source pixel contributes where its centre lands inside the
// screen. The significance map is sampled at its own resolution (pixel centres), so areas are
// sums over map pixels, each weighted by the Jacobian determinant of the triangle holding it.
//
// Plain data in, plain data out; thread-safe (no state).
#pragma once

#include <optional>
#include <vector>

#include "tiles/raster.h"
#include "warp/core/mesh.h"
#include "warp/core/view.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

struct ViewMetrics {
  std::optional<double> scale_gain;
  std::optional<double> anisotropy_salient, anisotropy_weighted;
  std::optional<double> straightness;  // none: no lines on screen, or no mesh
  std::optional<int> folds;
  double coverage = 0;
};

// The metrics of a view with a mesh. `traditional` is traditional zoom at the same request;
// `significance` the map that defines the salient region (image pixels via its scale); `lines`
// in image pixels.
ViewMetrics mesh_view_metrics(const View& view, const View& traditional, const SignificanceMap& significance,
                              const std::vector<Segment>& lines, int screen_width, int screen_height);

// The metrics of a method without a mesh, from its rendered screen and what each screen pixel
// shows (Retargeter::screen_sources, image px, NaN where nothing): coverage = share of pixels
// that show an image point (without sources: of rendered pixels not of the letterbox colour —
// every channel 0, or alpha 0 — which undercounts black image content); scale gain = screen pixels showing
// the salient region ÷ the same count under traditional zoom (`traditional`, at the same
// request) — pixels counted, which for a mesh view is the area measure above; the rest not
// applicable (no triangles to measure). Empty `sources`: coverage only.
ViewMetrics raster_view_metrics(const tiles::Raster& screen, const std::vector<Point>& sources, const View& traditional,
                                const SignificanceMap& significance);

// The pieces, for tests and for other measures.

// σ1/σ2 of the affine map taking triangle (a, b, c) to (a', b', c'): ∞ for a degenerate image.
double anisotropy(const Point& a, const Point& b, const Point& c, const Point& a2, const Point& b2, const Point& c2);

// Emitted triangles (view.visible) whose screen signed area is ≤ 0.
int fold_count(const View& view);

// Share of the screen's pixel centres inside some visible triangle.
double coverage(const View& view, int screen_width, int screen_height);

// The largest distance (same units as `points`) of `points` from the line through the first and
// last of them; 0 for fewer than three points.
double chord_deviation(const std::vector<Point>& points);

// Best similarity fit (Umeyama 1991, rotation without reflection) of `to` ≈ s·R·from + t: the RMS
// residual divided by s × the RMS radius of `from` about its centroid — dimensionless, 0 when `to`
// is a similar copy of `from`. Same sizes, ≥ 2 distinct points; otherwise NaN.
double similarity_fit_residual(const std::vector<Point>& from, const std::vector<Point>& to);

}  // namespace zoomwarp::warp
