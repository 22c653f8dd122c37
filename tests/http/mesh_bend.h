// How far a /mesh body bends straight lines, as a client sees it (issue 30): the body's triangles
// (source (u, v) → screen (x, y)) taken as a warp::View, and each line of a GET …/lines body
// ("lines", the curator's, and "suggested", the detected ones not dismissed) measured on it by
// the comparison metrics' own warp::line_bend (warp/compare/metrics.h): its largest distance
// from the chord through its mapped ends, exact for the piecewise-affine warp. Only lines whose
// chord on screen is at least warp::kMinMeasuredLinePx long count.
//
// Plain data in and out; thread-safe.
#pragma once

#include <nlohmann/json.hpp>

namespace zoomwarp::testing {

struct MeshLineBend {
  int measured = 0;      // lines measured
  double worst_px = 0;   // the largest bend, screen px
};

MeshLineBend worst_line_bend(const nlohmann::json& mesh, const nlohmann::json& lines);

}  // namespace zoomwarp::testing
