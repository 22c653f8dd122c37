#include "warp/compare/smart_crop.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace zoomwarp::warp {

Point attention_crop_centre(const tiles::Raster& image, double W, double H, int sw, int sh) {
  const Point middle{W / 2, H / 2};
  if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 || sw <= 0 || sh <= 0)
    return middle;
  const cv::Mat src(image.height, image.width, CV_8UC(image.channels), const_cast<std::uint8_t*>(image.pixels.data()));
  cv::Mat rgb;
  if (image.channels <= 2) {
    cv::Mat grey;
    cv::extractChannel(src, grey, 0);
    cv::cvtColor(grey, rgb, cv::COLOR_GRAY2RGB);
  } else if (image.channels == 4) {
    cv::cvtColor(src, rgb, cv::COLOR_RGBA2RGB);
  } else {
    rgb = src;
  }
  cv::Mat lab;
  rgb.convertTo(lab, CV_32F, 1.0 / 255);
  cv::cvtColor(lab, lab, cv::COLOR_RGB2Lab);  // L in [0, 100], a and b signed
  cv::Mat channels[3];
  cv::split(lab, channels);
  const cv::Mat &L = channels[0], &a = channels[1], &b = channels[2];
  cv::Mat gx, gy;
  cv::Sobel(L, gx, CV_32F, 1, 0, 3);
  cv::Sobel(L, gy, CV_32F, 0, 1, 3);
  cv::Mat score = cv::abs(gx) + cv::abs(gy);
  cv::Mat skin = (a >= 3) & (a <= 22) & (b >= 4) & (b <= 31) & (L >= 15);
  cv::Mat chroma;
  cv::magnitude(a, b, chroma);
  cv::Mat saturated = chroma > 60;
  cv::Mat masks;
  skin.convertTo(masks, CV_32F);  // 255 where skin
  score += masks;
  saturated.convertTo(masks, CV_32F);
  score += masks;
  // The crop in this image's pixels, then in 32 × 32 cells.
  const double s = std::max(double(sw) / W, double(sh) / H), f = image.width / W;
  const double crop_w = std::min(W, sw / s) * f, crop_h = std::min(H, sh / s) * f;
  const double cell_w = image.width / 32.0, cell_h = image.height / 32.0;
  cv::Mat cells;
  cv::resize(score, cells, {32, 32}, 0, 0, cv::INTER_AREA);
  const double sigma = std::hypot(crop_w / cell_w, crop_h / cell_h) / 6;
  if (sigma > 0) cv::GaussianBlur(cells, cells, {0, 0}, sigma, sigma, cv::BORDER_REPLICATE);
  cv::Point best;
  cv::minMaxLoc(cells, nullptr, nullptr, nullptr, &best);
  const double left = std::clamp(cell_w * best.x - crop_w / 2, 0.0, image.width - crop_w);
  const double top = std::clamp(cell_h * best.y - crop_h / 2, 0.0, image.height - crop_h);
  return {(left + crop_w / 2) / f, (top + crop_h / 2) / f};
}

}  // namespace zoomwarp::warp
