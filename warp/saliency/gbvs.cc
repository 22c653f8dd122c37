#include "warp/saliency/gbvs.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>
#include <opencv2/imgproc.hpp>

#include "warp/saliency/precision.h"

namespace zoomwarp::warp {

namespace {

// The image as three float planes r, g, b in [0, 1] (grey and grey+alpha: r = g = b; alpha ignored).
cv::Mat rgb_of(const tiles::Raster& image) {
  const cv::Mat in(image.height, image.width, CV_8UC(image.channels), const_cast<std::uint8_t*>(image.pixels.data()));
  cv::Mat rgb;
  switch (image.channels) {
    case 1: cv::cvtColor(in, rgb, cv::COLOR_GRAY2RGB); break;
    case 2: {
      cv::Mat grey;
      cv::extractChannel(in, grey, 0);
      cv::cvtColor(grey, rgb, cv::COLOR_GRAY2RGB);
      break;
    }
    case 4: cv::cvtColor(in, rgb, cv::COLOR_RGBA2RGB); break;
    default: rgb = in; break;
  }
  cv::Mat out;
  rgb.convertTo(out, CV_32FC3, 1.0 / 255);
  return out;
}

// [Harel06] reference code: levels 2, 3, 4 of a Gaussian pyramid whose level 1 is the image. A
// side already 1 px stays (cv::pyrDown would not shrink it: a 1×1 image is its own pyramid).
std::vector<cv::Mat> pyramid_levels(const cv::Mat& rgb) {
  std::vector<cv::Mat> levels;
  cv::Mat level = rgb;
  for (int k = 2; k <= 4; ++k) {
    if (level.cols >= 2 && level.rows >= 2) cv::pyrDown(level, level);
    levels.push_back(level);
  }
  return levels;
}

// Resized to the feature grid: area averaging when shrinking, bilinear when a level is smaller.
cv::Mat to_grid(const cv::Mat& m, cv::Size grid) {
  cv::Mat out;
  const bool shrinking = m.cols >= grid.width && m.rows >= grid.height;
  cv::resize(m, out, grid, 0, 0, shrinking ? cv::INTER_AREA : cv::INTER_LINEAR);
  return out;
}

// The reference code's Gabor filters: envelope σ = 2 px across, elongation 2 along the stripes,
// period π px; energy = |even| + |odd| response. The even kernel is made zero-mean, so a uniform
// area has no orientation energy.
cv::Mat gabor_energy(const cv::Mat& intensity, double degrees) {
  constexpr double kSigma = 2, kElongation = 2, kPeriod = std::numbers::pi;
  const int half = int(std::ceil(3 * kSigma * kElongation));
  const cv::Size size(2 * half + 1, 2 * half + 1);
  const double theta = degrees * std::numbers::pi / 180;
  cv::Mat even = cv::getGaborKernel(size, kSigma, theta, kPeriod, 1 / kElongation, 0, CV_32F);
  const cv::Mat odd = cv::getGaborKernel(size, kSigma, theta, kPeriod, 1 / kElongation, std::numbers::pi / 2, CV_32F);
  even -= cv::mean(even)[0];
  cv::Mat e, o;
  cv::filter2D(intensity, e, CV_32F, even, cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
  cv::filter2D(intensity, o, CV_32F, odd, cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
  return cv::abs(e) + cv::abs(o);
}

// The 21 feature maps of [Harel06] on the grid, grouped by channel: intensity, colour, orientation.
std::array<std::vector<cv::Mat>, 3> feature_maps(const cv::Mat& rgb, cv::Size grid) {
  std::array<std::vector<cv::Mat>, 3> channels;
  for (const cv::Mat& level : pyramid_levels(rgb)) {
    cv::Mat p[3];
    cv::split(level, p);
    const cv::Mat intensity = (p[0] + p[1] + p[2]) / 3;
    // Colour opponency, Itti's form: divided by the brightest component, so that it measures hue;
    // near-black pixels (max < 0.1) have none worth the name and get 0.
    cv::Mat brightest = cv::max(cv::max(p[0], p[1]), p[2]);
    const cv::Mat dark = brightest < 0.1f;
    brightest.setTo(1.0f, dark);
    cv::Mat red_green = (p[0] - p[1]) / brightest, blue_yellow = (p[2] - cv::min(p[0], p[1])) / brightest;
    red_green.setTo(0.0f, dark);
    blue_yellow.setTo(0.0f, dark);
    channels[0].push_back(to_grid(intensity, grid));
    channels[1].push_back(to_grid(red_green, grid));
    channels[1].push_back(to_grid(blue_yellow, grid));
    for (double angle : {0.0, 45.0, 90.0, 135.0}) channels[2].push_back(to_grid(gabor_energy(intensity, angle), grid));
  }
  return channels;
}

// exp(−d²/2σ²) between grid locations i and j (row-major, n × n): both graphs' distance factor.
std::vector<double> distance_kernel(cv::Size grid, double sigma) {
  const int n = grid.area();
  std::vector<double> k(std::size_t(n) * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double dx = i % grid.width - j % grid.width, dy = i / grid.width - j / grid.width;
      k[std::size_t(i) * n + j] = std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma));
    }
  return k;
}

// [Harel06], activation = equilibrium of the chain weighted by dissimilarity × proximity.
std::vector<double> activation(const cv::Mat& map, const std::vector<double>& kernel, const GbvsOptions& o) {
  const int n = int(map.total());
  const float* m = map.ptr<float>();
  std::vector<double> w(std::size_t(n) * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) w[std::size_t(i) * n + j] = std::abs(double(m[i]) - m[j]) * kernel[std::size_t(i) * n + j];
  return stationary_distribution(std::move(w), n, o.tolerance, o.max_iterations);
}

// [Harel06], normalisation = equilibrium of the chain that flows towards high activation
// nearby, so that mass concentrates on a few peaks instead of spreading over many.
std::vector<double> normalisation(const std::vector<double>& a, const std::vector<double>& kernel, const GbvsOptions& o) {
  const int n = int(a.size());
  std::vector<double> w(std::size_t(n) * n), start(n, 0.0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) start[i] += w[std::size_t(i) * n + j] = a[j] * kernel[std::size_t(i) * n + j];
    // Detailed balance: a_i·w_ij = a_i·a_j·k_ij is symmetric, so π_i ∝ a_i·Σ_j w_ij.
    start[i] *= a[i];
  }
  return stationary_distribution(std::move(w), n, o.tolerance, o.max_iterations, start);
}

}  // namespace

std::vector<double> stationary_distribution(std::vector<double> weights, int n, double tolerance, int max_iterations,
                                            const std::vector<double>& start) {
  if (n <= 0 || weights.size() != std::size_t(n) * n) throw std::invalid_argument("weights must be n × n, n ≥ 1");
  if (!start.empty() && start.size() != std::size_t(n)) throw std::invalid_argument("start must have n entries");
  // P = the weights with rows normalised, in place; a row without weight is a state that stays.
  std::vector<double>& p = weights;
  std::vector<double> degree(n, 0.0);
  for (int i = 0; i < n; ++i) {
    double* row = &p[std::size_t(i) * n];
    for (int j = 0; j < n; ++j) degree[i] += row[j];
    if (degree[i] > 0) {
      for (int j = 0; j < n; ++j) row[j] /= degree[i];
    } else {
      row[i] = 1;
    }
  }
  // Without a start, the degrees: for symmetric weights (the activation graph) that is π already,
  // by detailed balance (π_i·P_ij = w_ij / Σw). The limit does not depend on the start; a good
  // one saves the iterations.
  const std::vector<double>& guess = start.empty() ? degree : start;
  double total = 0;
  for (double d : guess) total += d;
  std::vector<double> pi(n), next(n);
  for (int i = 0; i < n; ++i) pi[i] = total > 0 ? guess[i] / total : 1.0 / n;
  for (int it = 0; it < max_iterations; ++it) {
    std::fill(next.begin(), next.end(), 0.0);
    for (int i = 0; i < n; ++i) {
      const double* row = &p[std::size_t(i) * n];
      const double mass = pi[i];
      for (int j = 0; j < n; ++j) next[j] += mass * row[j];
    }
    double change = 0;
    for (int j = 0; j < n; ++j) change = std::max(change, std::abs(next[j] - pi[j]));
    if (change < tolerance) break;
    // A step of the lazy chain (P + I)/2: the same π, and no oscillation where the graph is
    // bipartite (a two-valued map: every edge joins the two values).
    double sum = 0;
    for (int j = 0; j < n; ++j) sum += pi[j] = (pi[j] + next[j]) / 2;
    for (double& v : pi) v /= sum;
  }
  return pi;
}

SignificanceMap compute_gbvs(const tiles::Raster& image, int image_width, int out_width, int out_height,
                             const GbvsOptions& o) {
  if (image.empty() || image_width < 1 || out_width < 1 || out_height < 1)
    throw std::invalid_argument("GBVS of an empty image");
  const double long_side = std::max(image.width, image.height);
  const cv::Size grid(std::max(1, int(std::lround(image.width / long_side * o.map_max_side))),
                      std::max(1, int(std::lround(image.height / long_side * o.map_max_side))));
  const double mean_side = (grid.width + grid.height) / 2.0;
  const std::vector<double> k_act = distance_kernel(grid, o.sigma_activation * mean_side);
  const std::vector<double> k_norm = distance_kernel(grid, o.sigma_normalisation * mean_side);

  cv::Mat master = cv::Mat::zeros(grid, CV_32F);
  for (const std::vector<cv::Mat>& channel : feature_maps(rgb_of(image), grid)) {
    cv::Mat sum = cv::Mat::zeros(grid, CV_32F);
    for (const cv::Mat& map : channel) {
      const std::vector<double> a = normalisation(activation(map, k_act, o), k_norm, o);
      for (int i = 0; i < int(a.size()); ++i) sum.at<float>(i / grid.width, i % grid.width) += float(a[i]);
    }
    master += sum / double(channel.size());
  }
  cv::GaussianBlur(master, master, cv::Size(0, 0), o.blur * std::max(grid.width, grid.height), 0, cv::BORDER_REPLICATE);
  double lo = 0, hi = 0;
  cv::Mat out;
  cv::resize(master, out, cv::Size(out_width, out_height), 0, 0, cv::INTER_LINEAR);
  // Rescaled after upsampling, so that the maximum is exactly 1 (samples need not hit the grid's extremes).
  cv::minMaxLoc(out, &lo, &hi);
  out = hi > lo ? cv::Mat(cv::min(cv::max((out - lo) / (hi - lo), 0.0), 1.0)) : cv::Mat::zeros(out.size(), CV_32F);
  SignificanceMap map;
  map.width = out_width;
  map.height = out_height;
  map.scale = double(out_width) / image_width;
  map.values.assign(out.begin<float>(), out.end<float>());
  return map;
}

SignificanceMap gbvs_significance(const tiles::Raster& image, int image_width, const SignificanceOptions& options) {
  SignificanceMap map = compute_gbvs(image, image_width, image.width, image.height);
  paint_faces(map, faces_of(image, options));
  quantise(map);  // at the precision it is stored at (precision.h)
  return map;
}

}  // namespace zoomwarp::warp
