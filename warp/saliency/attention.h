// [Kumar (004) §III-B] object selection on a saliency map: the map is binarised by an adaptive
// threshold (004 names none; ours: Otsu's, on the map quantised to 8 bits), the binary map's
// 8-connected components are the candidate objects R, and each is ranked by its attention value
//
//   AV_R = Σ_{(k,l) ∈ R} B_kl · W_kl                                   [Kumar (004) eq. 4]
//
// B the saliency, W a Gaussian centred on the map with σx = width/4, σy = height/4 (ours; 004
// gives none), normalised to sum 1 over the map. GBVS already favours the centre (border nodes
// have fewer neighbours): W counts it again, so use AV to rank regions, not as a saliency.
//
// Thread safety: pure functions.
#pragma once

#include <vector>

#include "tiles/raster.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

struct AttentionRegion {
  int label = 0;        // its value in AttentionRegions::labels (1, 2, …)
  tiles::Rect box;      // bounding box, map pixels
  long long area = 0;   // map pixels
  double attention = 0; // AV_R
};

struct AttentionRegions {
  int width = 0, height = 0;
  std::vector<int> labels;  // per map pixel, row-major: 0 below the threshold, else its region's label
  std::vector<AttentionRegion> regions;  // in label order
  float threshold = 0;      // Otsu's threshold, in map values [0, 1]

  // The regions worth keeping: attention ≥ `fraction` × the largest (mp keeps ≥ 0.1).
  std::vector<AttentionRegion> kept(double fraction = 0.1) const;
};

// The regions of `map` (values in [0, 1]). A map without contrast (all values equal) has no
// region: Otsu's threshold would split nothing from nothing.
AttentionRegions attention_regions(const SignificanceMap& map);

}  // namespace zoomwarp::warp
