// `fit=` of a view (issue 41): what zoom 0 does with an image whose aspect ratio is not the
// screen's. A warp of the whole image onto a phone screen squeezes what matters about as much as
// a uniform stretch would once the aspect change is large; RetargetMe's study [Rubinstein10]
// found that people prefer cropping, or crop and warp together, at such changes. So:
//
//   auto  warp within a distortion budget and crop what matters least for the rest: the
//         method's warp at zoom 0 keeps the salient anisotropy (what matters, as the view's map
//         sees it) at p90 ≤ `max_distortion`; the warp's target keeps as much of the aspect
//         change as that allows, and the screen shows the part of it with the screen's aspect
//         (view_window.h fits the frame and places the window). An aspect change within the
//         budget is warped whole, as `warp`. The default.
//   warp  the whole image warped to the screen's aspect ([ICAZ §5.1]'s global view): every view
//         before fit=.
//   crop  a content-aware crop: no warp, the screen covered by the image, placed as `auto` is.
//   pad   the whole image undistorted, with bands.
//
// Plain data; thread-safe.
#pragma once

#include <optional>
#include <string_view>

namespace zoomwarp::warp {

enum class Fit { kAuto, kWarp, kCrop, kPad };

// The accepted `max_distortion=` values: the salient anisotropy (σ1/σ2, p90) the warp may reach,
// and the largest ratio of a uniform stretch's two scales a method that cannot be measured (no
// mesh) absorbs. 1 crops everything away that does not fit (as `crop`, but warped); the upper end
// is beyond any screen a client has (4096×16 against 16×4096 is 65 536, but no view is worth
// that: past 8 the result is a sliver either way).
inline constexpr double kMinMaxDistortion = 1.0, kMaxMaxDistortion = 8.0;

// The default budget, chosen on pictures and on measures the methods do not optimise
// (docs/compare.md, "fit=auto"): over 24 photographs on both phone screens, 1.4 keeps the salient
// anisotropy under an independent saliency model at p90 ≤ 1.47 and p99 ≤ 1.75 for icaz, polyfem,
// patch and retarget-zoom (mp 1.53, 2.25 on one view each); 1.5 let 2–11 of each method's 48
// views past p90 1.5 for two to three fewer views short of 1.4 × a smart crop's coverage.
inline constexpr double kDefaultMaxDistortion = 1.4;

// What a view without `fit=` gets.
inline constexpr Fit kDefaultFit = Fit::kAuto;

struct FitOptions {
  Fit fit = kDefaultFit;
  double max_distortion = kDefaultMaxDistortion;
};

std::string_view fit_name(Fit fit);
std::optional<Fit> parse_fit(std::string_view name);  // "auto", "warp", "crop", "pad"; else none

// Whether views of this fit warp the image: crop and pad do not, so any method draws them by
// traditional zoom.
inline bool fit_warps(Fit fit) { return fit == Fit::kAuto || fit == Fit::kWarp; }

}  // namespace zoomwarp::warp
