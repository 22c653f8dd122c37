#include "warp/saliency/precision.h"

#include <algorithm>
#include <cmath>

namespace zoomwarp::warp {

float quantised_significance(float v) {
  const double unit = v > 0 ? std::min(double(v), 1.0) : 0.0;
  return float(std::lround(unit * kSignificanceLevels)) / float(kSignificanceLevels);
}

void quantise(SignificanceMap& map) {
  for (float& v : map.values) v = quantised_significance(v);
}

}  // namespace zoomwarp::warp
