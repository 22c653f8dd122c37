#include "warp/methods/seam/seam_resolution.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace zoomwarp::warp {

SeamMapSize seam_map_size(int width, int height) {
  const int long_side = std::max(width, height);
  if (long_side <= kSeamMaxSide) return {width, height};
  const double f = double(kSeamMaxSide) / long_side;
  return {std::max(1, int(std::lround(width * f))), std::max(1, int(std::lround(height * f)))};
}

VisibilityMaps compute_seam_maps(const tiles::Raster& analysis, const SignificanceMap& saliency) {
  const SeamMapSize size = seam_map_size(analysis.width, analysis.height);
  if (size.width == analysis.width && size.height == analysis.height)
    return compute_visibility_maps(analysis, saliency);
  // Area averaging: every analysis pixel counts, as a pyramid level's would.
  const cv::Size to(size.width, size.height);
  tiles::Raster image(size.width, size.height, analysis.channels);
  const cv::Mat from(analysis.height, analysis.width, CV_8UC(analysis.channels),
                     const_cast<std::uint8_t*>(analysis.pixels.data()));
  cv::Mat into(size.height, size.width, CV_8UC(analysis.channels), image.pixels.data());
  cv::resize(from, into, to, 0, 0, cv::INTER_AREA);
  // The bias likewise, so that a salient spike thinner than a reduced pixel still counts.
  SignificanceMap bias;
  if (saliency.width > 0 && saliency.height > 0) {
    bias.width = size.width, bias.height = size.height;
    bias.scale = saliency.scale * size.width / saliency.width;
    bias.values.resize(std::size_t(size.width) * size.height);
    const cv::Mat s(saliency.height, saliency.width, CV_32F, const_cast<float*>(saliency.values.data()));
    cv::Mat b(size.height, size.width, CV_32F, bias.values.data());
    cv::resize(s, b, to, 0, 0, cv::INTER_AREA);
  }
  return compute_visibility_maps(image, bias);
}

bool seam_maps_fit(const VisibilityMaps& maps, int width, int height) {
  const SeamMapSize reduced = seam_map_size(width, height);
  const int w = maps.horizontal.length, h = maps.horizontal.lines;
  return (w == reduced.width && h == reduced.height) || (w == width && h == height);
}

}  // namespace zoomwarp::warp
