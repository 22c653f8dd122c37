#include "warp/saliency/attention.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace zoomwarp::warp {

std::vector<AttentionRegion> AttentionRegions::kept(double fraction) const {
  double top = 0;
  for (const AttentionRegion& r : regions) top = std::max(top, r.attention);
  std::vector<AttentionRegion> out;
  for (const AttentionRegion& r : regions)
    if (r.attention >= fraction * top) out.push_back(r);
  return out;
}

AttentionRegions attention_regions(const SignificanceMap& map) {
  AttentionRegions out;
  out.width = map.width;
  out.height = map.height;
  out.labels.assign(map.values.size(), 0);
  if (map.values.empty()) return out;
  const auto [lo, hi] = std::minmax_element(map.values.begin(), map.values.end());
  if (*lo == *hi) return out;

  const cv::Mat values(map.height, map.width, CV_32F, const_cast<float*>(map.values.data()));
  cv::Mat bytes, binary;
  values.convertTo(bytes, CV_8U, 255);
  out.threshold = float(cv::threshold(bytes, binary, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU) / 255);
  cv::Mat labels(map.height, map.width, CV_32S, out.labels.data()), stats, centroids;
  const int count = cv::connectedComponentsWithStats(binary, labels, stats, centroids, 8, CV_32S);

  // W: the centred Gaussian, normalised over the map [Kumar (004) eq. 4].
  const double cx = (map.width - 1) / 2.0, cy = (map.height - 1) / 2.0;
  const double sx = map.width / 4.0, sy = map.height / 4.0;
  std::vector<double> wx(map.width), wy(map.height);
  for (int x = 0; x < map.width; ++x) wx[x] = std::exp(-(x - cx) * (x - cx) / (2 * sx * sx));
  for (int y = 0; y < map.height; ++y) wy[y] = std::exp(-(y - cy) * (y - cy) / (2 * sy * sy));
  double w_total = 0;
  for (double a : wx)
    for (double b : wy) w_total += a * b;

  out.regions.resize(std::size_t(count - 1));
  for (int k = 1; k < count; ++k) {
    AttentionRegion& r = out.regions[std::size_t(k - 1)];
    r.label = k;
    r.box = {stats.at<int>(k, cv::CC_STAT_LEFT), stats.at<int>(k, cv::CC_STAT_TOP), stats.at<int>(k, cv::CC_STAT_WIDTH),
             stats.at<int>(k, cv::CC_STAT_HEIGHT)};
    r.area = stats.at<int>(k, cv::CC_STAT_AREA);
  }
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x)
      if (const int k = out.labels[std::size_t(y) * map.width + x]; k > 0)
        out.regions[std::size_t(k - 1)].attention += map.at(x, y) * wx[x] * wy[y] / w_total;
  return out;
}

}  // namespace zoomwarp::warp
