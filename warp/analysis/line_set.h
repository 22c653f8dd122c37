// Which straight lines a warp keeps straight (issue 30, `lines=` of /viewport and /mesh):
//
//   auto     the default: the curator's lines and the detected ones the curator neither dismissed
//            nor drew (detected_lines.h suggested_lines) — [ICAZ §4.3]'s line constraint fed with
//            [Guo09 §3.3.3]'s detected lines, so that a squeeze does not bend a tower or a roof
//            line nobody has drawn yet;
//   curator  the curator's lines only (the default before issue 30);
//   none     no line constraint at all.
//
// A method that takes no lines (traditional zoom, seam carving) gives the same view for each.
#pragma once

#include <array>
#include <optional>
#include <string_view>

namespace zoomwarp::warp {

enum class LineSet { kAuto, kCurator, kNone };

inline constexpr std::array<LineSet, 3> kLineSets = {LineSet::kAuto, LineSet::kCurator, LineSet::kNone};

inline std::string_view line_set_name(LineSet s) {
  return s == LineSet::kAuto ? "auto" : s == LineSet::kCurator ? "curator" : "none";
}

inline std::optional<LineSet> parse_line_set(std::string_view name) {
  for (LineSet s : kLineSets)
    if (line_set_name(s) == name) return s;
  return std::nullopt;
}

}  // namespace zoomwarp::warp
