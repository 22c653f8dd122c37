#include "warp/window/fit.h"

namespace zoomwarp::warp {

std::string_view fit_name(Fit fit) {
  switch (fit) {
    case Fit::kAuto: return "auto";
    case Fit::kWarp: return "warp";
    case Fit::kCrop: return "crop";
    case Fit::kPad: return "pad";
  }
  return "auto";
}

std::optional<Fit> parse_fit(std::string_view name) {
  for (Fit f : {Fit::kAuto, Fit::kWarp, Fit::kCrop, Fit::kPad})
    if (name == fit_name(f)) return f;
  return std::nullopt;
}

}  // namespace zoomwarp::warp
