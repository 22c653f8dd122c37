// The precision of every saliency map's values (SignificanceMap, both kinds): multiples of
// 1 / kSignificanceLevels, one byte each in the files (analysis/compact_map.h). Maps are made at
// that precision — computed (compute_significance, gbvs_significance), painted (paint_polygon
// rounds the curator's weight) or read back — so a map rebuilt in memory is the stored one value
// for value, and the node means made from either agree. 8 bits: 16 would take the map's file
// from ~0.28 to ~1 MB, and with 8 the compare metrics of icaz, retarget-zoom, mp and patch moved
// ≤ 0.3 %, polyfem's ≤ 4.2 % (docs/ingest.md, "Compact analysis files (issue 28)").
//
// Thread safety: plain functions; thread-safe.
#pragma once

#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

inline constexpr int kSignificanceLevels = 255;

// `v` clamped to [0, 1] (NaN: 0) and rounded to the nearest multiple of 1 / kSignificanceLevels.
float quantised_significance(float v);
void quantise(SignificanceMap& map);

}  // namespace zoomwarp::warp
