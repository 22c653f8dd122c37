#include "warp/analysis/analysis_image.h"

#include <algorithm>

#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

int analysis_level(const tiles::Manifest& m) {
  int k = 0;
  while (k + 1 < m.levels && std::max(m.level_width(k), m.level_height(k)) > kSignificanceMaxSide) ++k;
  return k;
}

tiles::Raster read_reduced_image(const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  const tiles::Manifest& m = image.manifest;
  const int k = analysis_level(m);
  return reader.read_level(image, k, {0, 0, m.level_width(k), m.level_height(k)});
}

}  // namespace zoomwarp::warp
