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
//   rotation        each triangle's affine map A (source → screen) turns shapes by the angle of
//                   the rotation closest to A (its polar factor [Higham 1986]; for a 2×2 matrix
//                   θ = atan2(A₁₀ − A₀₁, A₀₀ + A₁₁)); a stretch along the axes, uniform or not,
//                   has θ = 0. Reported as the 95th percentile of |θ| over the salient region's
//                   on-screen area (each salient map pixel weighted by its area on screen, as
//                   for the gain: "rotation_p95"), and as the standard deviation of the signed θ
//                   about its mean, weighted by on-screen significance mass as the weighted
//                   anisotropy is ("rotation_spread"), degrees. The spread is what bends: a
//                   rotation that differs from place to place turns a straight edge into a curve,
//                   while a whole view turned by one angle bends nothing (spread 0, p95 = |θ|).
//                   θ ∈ (−180°, 180°]; the spread does not wrap around ±180° (a view turned
//                   that far is upside down, not bent);
//   straightness    per line (the curator's and the detected ones the curator did not dismiss,
//                   as the caller passes them), the largest distance of its warped image on
//                   screen from the chord through the first and last of its points on screen,
//                   screen px [ICAZ §4.3]; exact for a piecewise-affine warp: the line is cut at
//                   every triangle edge it crosses and at the screen border, and its screen image
//                   is the polyline through those points. Only lines whose chord on screen is at
//                   least kMinMeasuredLinePx long count (a shorter one cannot visibly bend, issue
//                   30: "every detected line ≥ 8 screen px long bent ≤ 2 px on screen"); the
//                   worst of them is reported, and how many there were;
//   folds           emitted (visible) triangles with signed screen area ≤ 0; must be 0;
//   coverage        share of screen pixels (centres) covered by the visible triangles; 1 for every
//                   retargeting method at every zoom (traditional zoom letterboxes).
//
// Only what is on screen counts: a source pixel contributes where its centre lies in a triangle
// of the view's mesh and lands inside the screen. The significance map is sampled at its own
// resolution (pixel centres), so areas are sums over map pixels, each weighted by the Jacobian
// determinant of the triangle holding it; each triangle is rasterised over the map's pixel grid
// (map_pixel_triangles), O(map pixels + triangles) per view.
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

// Issue 41's squash measures of a view against a saliency map — the server's, or one no method
// optimises (independent_saliency.h) — whose salient part is the top fifth of the map's pixels
// by value (a flat map: a fifth of them, by position):
//   anisotropy p90 / p99  σ1/σ2 of the triangle holding each salient pixel centre that lands on
//                         the screen, each pixel weighing the same (its source area);
//   coverage              the share of the salient part's map mass whose pixel centres land on
//                         the screen (1: nothing salient is cropped away).
// A uniform stretch of the whole image gives anisotropy (W/H)/(w/h) or its inverse everywhere and
// coverage 1; a crop gives anisotropy 1 and the crop's share.
struct SquashMeasures {
  std::optional<double> anisotropy_p90, anisotropy_p99;  // none: nothing salient on screen, or no mesh
  std::optional<double> coverage;                        // none: an empty map
};

struct ViewMetrics {
  std::optional<double> scale_gain;
  std::optional<double> anisotropy_salient, anisotropy_weighted;
  std::optional<double> rotation_p95, rotation_spread;  // degrees
  std::optional<double> straightness;  // none: no line measured, or no mesh
  std::optional<int> lines_measured;   // lines with a chord ≥ kMinMeasuredLinePx on screen; none: no mesh
  std::optional<int> folds;
  double coverage = 0;
  SquashMeasures squash;  // against the map the metrics were given (the server's)
};

// The squash measures of a view with a mesh.
SquashMeasures squash_measures(const View& view, const SignificanceMap& map, int screen_width, int screen_height);

// The same for a method without a mesh, from what each screen pixel shows (image px, NaN where
// nothing is; Retargeter::screen_sources): coverage only — a salient map pixel counts as shown
// when a screen pixel shows a point of it.
SquashMeasures squash_measures_of_sources(const std::vector<Point>& sources, const SignificanceMap& map);

// A line counts for straightness when its chord on screen is at least this long (screen px).
inline constexpr double kMinMeasuredLinePx = 8;

// The metrics of a view with a mesh. `traditional` is traditional zoom at the same request;
// `significance` the map that defines the salient region (image pixels via its scale); `lines`
// in image pixels (`zoomwarp compare` passes the curator's and the suggested ones,
// detected_lines.h).
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

// The angle θ, degrees, of the rotation closest to the affine map taking triangle (a, b, c) to
// (a', b', c') (its linear part A: θ = atan2(A₁₀ − A₀₁, A₀₀ + A₁₁)); positive turns +x towards +y
// (clockwise on a y-down screen); NaN for a degenerate source triangle.
double rotation_degrees(const Point& a, const Point& b, const Point& c, const Point& a2, const Point& b2,
                        const Point& c2);

// A value with its weight, for the weighted statistics below.
struct Weighted {
  double value = 0, weight = 0;
};

// The weighted q-quantile (q in [0, 1]): the smallest value whose cumulative weight, values in
// ascending order, reaches q × the total. NaN without positive weight.
double weighted_quantile(std::vector<Weighted> values, double q);

// The weighted standard deviation about the weighted mean, √(Σw(v − v̄)² / Σw). NaN without
// positive weight.
double weighted_spread(const std::vector<Weighted>& values);

// The triangle of `mesh` holding each pixel centre ((x + 0.5) / scale, (y + 0.5) / scale) of a
// width × height grid (a significance map's), row-major; −1 for a centre off the mesh. The
// triangle is locate_in's (TriangleLocator's): the first in mesh order whose barycentric
// coordinates are all ≥ 0, or, for a centre on an edge that rounding puts a hair outside every
// triangle, the first of those nearest to it. Unlike locate_in, a centre outside every triangle
// has none (the view does not draw it) rather than the nearest one's extrapolation. Each triangle
// is rasterised over the grid: O(pixels + triangles).
std::vector<int> map_pixel_triangles(const Mesh& mesh, int width, int height, double scale);

// Line `s` (image px) on the view's screen: its largest distance from its chord, screen px, with
// the chord's length — exact for the piecewise-affine warp (the polyline through the points
// where `s` crosses a visible triangle's edge or the screen border, the part on screen). None
// when no part of `s` is shown.
struct LineBend {
  double deviation = 0, chord = 0;
};
std::optional<LineBend> line_bend(const View& view, const Segment& s, int screen_width, int screen_height);

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
