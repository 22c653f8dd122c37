// Which saliency map drives a content-aware method (`saliency=` on a request; docs/algorithms.md
// "Saliency"): `default` is significance.h's gradient × spectral residual [ICAZ §4]; `gbvs` is
// Graph-Based Visual Saliency [Harel06] as [Kumar §III-B] uses it (gbvs.h). Both have faces and
// the curator's edits painted in; every content-aware method keeps its precomputation per kind.
#pragma once

#include <array>
#include <optional>
#include <string_view>

namespace zoomwarp::warp {

enum class Saliency { kDefault, kGbvs };

inline constexpr std::array<Saliency, 2> kSaliencies = {Saliency::kDefault, Saliency::kGbvs};

inline std::string_view saliency_name(Saliency s) { return s == Saliency::kGbvs ? "gbvs" : "default"; }

inline std::optional<Saliency> parse_saliency(std::string_view name) {
  for (Saliency s : kSaliencies)
    if (saliency_name(s) == name) return s;
  return std::nullopt;
}

}  // namespace zoomwarp::warp
