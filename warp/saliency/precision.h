// The precision of every saliency map's values (SignificanceMap, both kinds): multiples of
// 1 / kSignificanceLevels, two bytes each in the files (analysis/compact_map.h). Maps are made at
// that precision — computed (compute_significance, gbvs_significance), painted (paint_polygon
// rounds the curator's weight) or read back — so a map rebuilt in memory is the stored one value
// for value, and the node means made from either agree. 16 bits, not 8: at 8 (a quarter of the
// bytes) the metrics moved ≤ 0.3 % but ICAZ folded one triangle of the 4:1 panorama at 360×640
// (tests/http/http_views_test.cc): the shape energy's weights are the map, and a step of 1/255
// moved the solve across its margin (docs/ingest.md, "Compact analysis files (issue 28)").
//
// Thread safety: plain functions; thread-safe.
#pragma once

#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

inline constexpr int kSignificanceLevels = 65535;

// `v` clamped to [0, 1] (NaN: 0) and rounded to the nearest multiple of 1 / kSignificanceLevels.
float quantised_significance(float v);
void quantise(SignificanceMap& map);

}  // namespace zoomwarp::warp
