#include "warp/window/view_window.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "warp/core/triangle_locator.h"
#include "warp/core/uniform_zoom.h"

namespace zoomwarp::warp {

SignificanceProfile significance_profile(const SignificanceMap& map, const std::vector<SignificanceEdit>& edits,
                                         double width, double height) {
  SignificanceProfile p;
  p.width = width, p.height = height;
  p.column_mass.assign(std::max(map.width, 0), 0.0), p.row_mass.assign(std::max(map.height, 0), 0.0);
  p.column_important = p.column_mass, p.row_important = p.row_mass;
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x) {
      const double v = map.at(x, y);
      p.column_mass[x] += v, p.row_mass[y] += v;
    }
  // The important regions painted on a blank map of the same grid (the regions are polygons in
  // image pixels; paint_polygon rasterises them as the significance edits were).
  SignificanceMap important{map.width, map.height, map.scale, std::vector<float>(map.values.size(), 0.0f)};
  bool any = false;
  for (const SignificanceEdit& e : edits)
    if (e.weight >= kImportantWeight) paint_polygon(important, e.polygon, 1.0f), any = true;
  if (any)
    for (int y = 0; y < map.height; ++y)
      for (int x = 0; x < map.width; ++x)
        if (important.at(x, y) > 0) p.column_important[x] += 1, p.row_important[y] += 1;
  return p;
}

namespace {

// Mass of bins [0, t) for a fractional bin index t (each bin spread evenly over its width).
struct Cumulative {
  std::vector<double> prefix;  // prefix[k] = Σ bins [0, k)
  explicit Cumulative(const std::vector<double>& bins) : prefix(bins.size() + 1, 0.0) {
    for (std::size_t k = 0; k < bins.size(); ++k) prefix[k + 1] = prefix[k] + bins[k];
  }
  double at(double t) const {
    const double n = double(prefix.size() - 1);
    t = std::clamp(t, 0.0, n);
    const std::size_t k = std::min(std::size_t(t), prefix.size() - 2);
    return prefix[k] + (t - double(k)) * (prefix[k + 1] - prefix[k]);
  }
  double between(double a, double b) const { return at(b) - at(a); }
};

// The share of a window, at each side, whose significance counts against it (ours, issue 41):
// what lies at a window's edge is what the crop cuts through, so there the weight falls linearly
// from 1 to −1 and a subject whole inside beats one cut at the edge — the fig on its plate at
// 360×640 was cut through its skin by the window of most significance, which took the plate's
// textured rim instead (smart croppers weigh their border alike: smartcrop.js's edge penalty).
constexpr double kEdgeShare = 0.1;

// ∫₀ᵘ of the weight of relative position t ∈ [0, 1] in a window: 1 inside, −1 + 2d/e at distance
// d < e = kEdgeShare from an edge. Integrated exactly over each bin below, so a window's score is
// continuous in its start (a flat map then ties everywhere, and the middle wins).
double edge_weight_integral(double u) {
  constexpr double e = kEdgeShare;
  u = std::clamp(u, 0.0, 1.0);
  const auto rim = [](double v) { return -v + v * v / e; };  // ∫₀^v (−1 + 2t/e) dt, v ≤ e
  if (u <= e) return rim(u);
  if (u <= 1 - e) return u - e;
  return (1 - 2 * e) - rim(1 - u);
}

// Σ over bins k of mass[k]·(the mean weight over the part of [lo(k), hi(k)) inside the window
// [a, a + length))·(that part's share of the bin): the bins' mass spread evenly over their extent.
template <class Lo, class Hi>
double edge_weighted_mass(const std::vector<double>& mass, Lo lo, Hi hi, double a, double length) {
  double sum = 0;
  for (std::size_t k = 0; k < mass.size(); ++k) {
    const double u0 = (lo(k) - a) / length, u1 = (hi(k) - a) / length;
    if (u1 <= 0 || u0 >= 1 || mass[k] == 0) continue;
    if (u1 - u0 <= 0) continue;  // a bin the warp folded to nothing shows nothing
    sum += mass[k] * (edge_weight_integral(u1) - edge_weight_integral(u0)) / (u1 - u0);
  }
  return sum;
}

// The best of the windows considered: the most important area, then the most edge-weighted
// significance, then the start nearest `middle` (equal within a billionth of the totals).
class BestWindow {
 public:
  BestWindow(double important_total, double mass_total, double middle)
      : eps_imp_(1e-9 * std::max(1.0, important_total)), eps_mass_(1e-9 * std::max(1.0, mass_total)), middle_(middle) {}

  void consider(double start, double important, double mass) {
    const bool better = !any_ || important > imp_ + eps_imp_ ||
                        (important >= imp_ - eps_imp_ &&
                         (mass > mass_ + eps_mass_ ||
                          (mass >= mass_ - eps_mass_ && std::abs(start - middle_) < std::abs(start_ - middle_))));
    if (better) any_ = true, start_ = start, imp_ = important, mass_ = mass;
  }
  double start() const { return start_; }

 private:
  const double eps_imp_, eps_mass_, middle_;
  bool any_ = false;
  double start_ = 0, imp_ = 0, mass_ = 0;
};

// The start (image px) of the `length`-long window along an axis of `extent` px (BestWindow).
double best_start(const std::vector<double>& mass, const std::vector<double>& important, double extent, double length) {
  const double n = double(mass.size());
  if (n == 0 || length >= extent) return 0;
  const double bins_per_px = n / extent, span = length * bins_per_px, last = n - span;
  const Cumulative m(mass), imp(important);
  BestWindow best(imp.at(n), m.at(n), last / 2);
  const auto consider = [&](double s) {
    best.consider(s, imp.between(s, s + span),
                  edge_weighted_mass(mass, [](std::size_t j) { return double(j); }, [](std::size_t j) { return j + 1.0; }, s, span));
  };
  // The middle, every start on the bins' grid, and the last.
  consider(last / 2);
  const int steps = int(std::ceil(last));
  for (int k = 0; k <= steps; ++k) consider(std::min(double(k), last));
  return best.start() / bins_per_px;
}

// The frame whose target keeps `allowance` of the aspect change (its uniform stretch): a₀ the
// image's aspect divided (multiplied, for a tall image) by it; none (the whole image, the
// screen's aspect) once the allowance holds the whole change. `crop_all` (fit=crop): a₀ the
// image's own.
WindowFrame frame_at(double W, double H, int sw, int sh, double allowance, bool crop_all) {
  WindowFrame out;
  const double image_aspect = W / H, screen_aspect = double(sw) / sh, change = image_aspect / screen_aspect;
  if (crop_all) allowance = 1;
  else if (std::max(change, 1 / change) <= allowance) return out;
  const double aspect0 = change > 1 ? image_aspect / allowance : image_aspect * allowance;
  ViewWindow& w = out.window;
  w.along_x = change > 1;
  // The screen shows the screen-shaped part of the a₀ target: a_S/a₀ of its width (a₀/a_S of its
  // height), taken as that share of the source.
  const double extent = w.along_x ? W : H;
  w.length = std::min(extent, w.along_x ? W * screen_aspect / aspect0 : H * aspect0 / screen_aspect);
  w.crops = w.length < extent;
  if (w.crops) out.frame = {aspect0, true};
  return out;
}

}  // namespace

WindowFrame window_frame(double W, double H, const FitOptions& fit, int sw, int sh, bool warps) {
  if (!std::isfinite(fit.max_distortion) || fit.max_distortion < kMinMaxDistortion || fit.max_distortion > kMaxMaxDistortion)
    throw std::invalid_argument("max_distortion must be between " + std::to_string(kMinMaxDistortion) + " and " +
                                std::to_string(kMaxMaxDistortion));
  if (fit.fit == Fit::kWarp || fit.fit == Fit::kPad || (fit.fit == Fit::kAuto && !warps)) return {};
  if (!(W > 0 && H > 0 && sw > 0 && sh > 0)) return {};
  return frame_at(W, H, sw, sh, fit.max_distortion, fit.fit == Fit::kCrop);
}

WindowFrame budgeted_frame(double W, double H, const FitOptions& fit, int sw, int sh, const SalientSqueeze& squeeze) {
  const WindowFrame first = window_frame(W, H, fit, sw, sh);
  const double budget = fit.max_distortion, ratio = (W / H) / (double(sw) / sh);
  const double change = std::max(ratio, 1 / ratio);
  if (fit.fit != Fit::kAuto || !(change > 1)) return first;
  const auto within = [&](double allowance) {
    const SalientSqueezeMeasure m = squeeze(frame_at(W, H, sw, sh, allowance, false));
    return m.p90 <= budget && m.p99 <= kSqueezeP99OverBudget * budget;
  };
  // Bisection on log(allowance) between one that holds (lo) and one that does not (hi): 1, a
  // plain crop, always holds. A change within the budget is warped whole if the warp holds it
  // (a method that squeezes what matters more than the stretch may not); beyond the budget, the
  // budget's own frame first, then the whole change.
  double lo = 1, hi = std::min(budget, change);
  if (!first.window.crops) {
    if (within(change)) return first;
  } else if (within(budget)) {
    if (within(change)) return frame_at(W, H, sw, sh, change, false);
    lo = budget, hi = change;
  }
  for (int k = 0; k < kBudgetBisections; ++k) {
    const double mid = std::sqrt(lo * hi);
    (within(mid) ? lo : hi) = mid;
  }
  return frame_at(W, H, sw, sh, lo, false);
}

void place_window(ViewWindow& w, const SignificanceProfile& p) {
  if (!w.crops) return;
  w.start = w.along_x ? best_start(p.column_mass, p.column_important, p.width, w.length)
                      : best_start(p.row_mass, p.row_important, p.height, w.length);
}

WindowFrame window_frame(const SignificanceProfile& p, const FitOptions& fit, int sw, int sh, bool warps) {
  WindowFrame out = window_frame(p.width, p.height, fit, sw, sh, warps);
  place_window(out.window, p);
  return out;
}

double window_offset(const ViewWindow& w, const SignificanceProfile& p) {
  if (!w.crops) return 0;
  return w.start + w.length / 2 - (w.along_x ? p.width : p.height) / 2;
}

double warped_window_offset(const View& v, const ViewWindow& w, const SignificanceProfile& p) {
  const std::vector<double>& mass = w.along_x ? p.column_mass : p.row_mass;
  const std::vector<double>& important = w.along_x ? p.column_important : p.row_important;
  const double extent = w.along_x ? p.width : p.height;
  const double target = w.along_x ? v.geometry.target_width : v.geometry.target_height;
  const double view = w.along_x ? v.geometry.view_width : v.geometry.view_height;
  const int n = int(mass.size());
  if (!w.crops || n == 0 || v.source.triangles.empty() || v.warped.size() != v.source.vertices.size() || !(target > view))
    return window_offset(w, p);
  // u[k]: where the k-th bin edge of the profile's axis lands in the warped image, along the
  // image's middle line (kept non-decreasing: a fold would only make it so locally).
  const TriangleLocator locator(v.source);
  const auto along = [&](const Point& q) { return w.along_x ? q.x : q.y; };
  std::vector<double> u(std::size_t(n) + 1);
  for (int k = 0; k <= n; ++k) {
    const double t = extent * k / n;
    const Point q = w.along_x ? Point{t, p.height / 2} : Point{p.width / 2, t};
    u[k] = along(locate(v.source, v.warped, q, locator.find(q)));
    if (k > 0) u[k] = std::max(u[k], u[k - 1]);
  }
  // The source position (in bins) that lands at warped coordinate x: u inverted piecewise linearly.
  const auto bin_at = [&](double x) {
    if (x <= u.front()) return 0.0;
    if (x >= u.back()) return double(n);
    const std::size_t k = std::size_t(std::upper_bound(u.begin(), u.end(), x) - u.begin());  // u[k-1] <= x < u[k]
    const double span = u[k] - u[k - 1];
    return double(k - 1) + (span > 0 ? (x - u[k - 1]) / span : 0.0);
  };
  // The screen-wide warped window with the most important area (counted a small margin inside
  // its edges, so that a region is not kept only to the pixel), then the most edge-weighted
  // significance (each bin spread over its warped extent); candidates: the middle, every warped
  // bin edge as the window's start or end, and both ends of the target.
  const Cumulative imp(important);
  const double margin = 0.02 * view, last = target - view;
  BestWindow best(imp.at(n), Cumulative(mass).at(n), last / 2);
  const auto consider = [&](double s) {
    s = std::clamp(s, 0.0, last);
    best.consider(s, imp.between(bin_at(s + margin), bin_at(s + view - margin)),
                  edge_weighted_mass(mass, [&](std::size_t k) { return u[k]; }, [&](std::size_t k) { return u[k + 1]; }, s, view));
  };
  consider(last / 2), consider(0), consider(last);
  for (double x : u) consider(x), consider(x - view);
  // The source point that lands at the chosen window's middle: the request centre that places it.
  return bin_at(best.start() + view / 2) * extent / n - extent / 2;
}

ViewRequest panned_view(const ViewRequest& r, const WindowFrame& f, double offset, double width, double height) {
  ViewRequest out = r;
  out.frame = f.frame;
  if (!f.window.crops || !std::isfinite(offset)) return out;
  const double z = std::clamp(std::isfinite(r.zoom) ? r.zoom : 0.0, 0.0, 1.0);
  if (f.window.along_x) out.cx = std::clamp(r.cx + offset * (1 - z), 0.0, width);
  else out.cy = std::clamp(r.cy + offset * (1 - z), 0.0, height);
  return out;
}

ViewRequest framed_view(const ViewRequest& r, const FitOptions& fit, const SignificanceProfile& p, bool warps) {
  const WindowFrame f = window_frame(p, fit, r.screen_width, r.screen_height, warps);
  return panned_view(r, f, window_offset(f.window, p), p.width, p.height);
}

}  // namespace zoomwarp::warp
