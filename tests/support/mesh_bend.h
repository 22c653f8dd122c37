// How far a /mesh body bends straight lines, as a client sees it (issue 30): each line of a
// GET …/lines body ("lines", the curator's, and "suggested", the detected ones not dismissed) is
// mapped through the mesh's triangles (source (u, v) → screen (x, y), piecewise affine) at every
// source pixel along it, and its bend is the largest distance of the mapped points from the chord
// through its mapped ends. Only lines whose mapped chord is at least `min_screen_px` long, and
// whose every sample lands in a listed triangle, are measured.
//
// Plain data in and out; thread-safe.
#pragma once

#include <nlohmann/json.hpp>

namespace zoomwarp::testing {

struct LineBend {
  int measured = 0;      // lines measured
  double worst_px = 0;   // the largest bend, screen px
};

LineBend worst_line_bend(const nlohmann::json& mesh, const nlohmann::json& lines, double min_screen_px);

}  // namespace zoomwarp::testing
