#include "warp/compare/independent_saliency.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace zoomwarp::warp {

SignificanceMap independent_saliency(const tiles::Raster& image, double image_width) {
  SignificanceMap out;
  if (image.width <= 0 || image.height <= 0 || image.pixels.empty() || !(image_width > 0)) return out;
  if (image.channels < 1 || image.channels > 4) return out;
  const cv::Mat src(image.height, image.width, CV_8UC(image.channels), const_cast<std::uint8_t*>(image.pixels.data()));
  cv::Mat grey;
  if (image.channels <= 2) cv::extractChannel(src, grey, 0);  // grey, or grey and alpha
  else cv::cvtColor(src, grey, image.channels == 3 ? cv::COLOR_RGB2GRAY : cv::COLOR_RGBA2GRAY);
  // Never enlarged: a smaller image is its own thumbnail.
  const double f = std::min(1.0, double(kIndependentSaliencySide) / std::max(image.width, image.height));
  const int tw = std::max(1, int(std::lround(image.width * f))), th = std::max(1, int(std::lround(image.height * f)));
  cv::Mat small;
  cv::resize(grey, small, {tw, th}, 0, 0, cv::INTER_AREA);  // the mean of each cell, as squash.py's Image.BOX
  cv::Mat planes[] = {cv::Mat_<double>(small), cv::Mat::zeros(th, tw, CV_64F)}, spectrum;
  cv::merge(planes, 2, spectrum);
  cv::dft(spectrum, spectrum);
  cv::split(spectrum, planes);
  cv::Mat amplitude, phase, log_amplitude, mean;
  cv::cartToPolar(planes[0], planes[1], amplitude, phase);
  cv::log(amplitude + 1e-9, log_amplitude);
  cv::blur(log_amplitude, mean, {3, 3}, {-1, -1}, cv::BORDER_REPLICATE);
  cv::Mat residual;
  cv::exp(log_amplitude - mean, residual);
  cv::polarToCart(residual, phase, planes[0], planes[1]);
  cv::merge(planes, 2, spectrum);
  cv::idft(spectrum, spectrum, cv::DFT_SCALE);
  cv::split(spectrum, planes);
  cv::Mat saliency;
  cv::magnitude(planes[0], planes[1], saliency);
  saliency = saliency.mul(saliency);
  cv::GaussianBlur(saliency, saliency, {19, 19}, 3, 3, cv::BORDER_REPLICATE);
  double lo = 0, hi = 0;
  cv::minMaxLoc(saliency, &lo, &hi);
  out.width = tw, out.height = th, out.scale = tw / image_width;
  out.values.resize(std::size_t(tw) * th);
  for (int y = 0; y < th; ++y)
    for (int x = 0; x < tw; ++x) out.values[std::size_t(y) * tw + x] = hi > 0 ? float(saliency.at<double>(y, x) / hi) : 0.0f;
  return out;
}

}  // namespace zoomwarp::warp
