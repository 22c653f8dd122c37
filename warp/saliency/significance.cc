#include "warp/saliency/significance.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <unordered_map>
#include <opencv2/core/utility.hpp>
#include <stdexcept>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>

#include "warp/saliency/precision.h"

namespace zoomwarp::warp {

namespace {

cv::Mat grey_of(const tiles::Raster& image) {
  const cv::Mat in(image.height, image.width, CV_8UC(image.channels), const_cast<std::uint8_t*>(image.pixels.data()));
  cv::Mat grey;
  if (image.channels == 1) grey = in.clone();
  else cv::cvtColor(in, grey, image.channels == 4 ? cv::COLOR_RGBA2GRAY : cv::COLOR_RGB2GRAY);
  return grey;
}

// Normalises to [0, 1] by the 99th percentile, so a few extreme pixels do not flatten the rest.
void normalise(cv::Mat& m) {
  std::vector<float> v(m.begin<float>(), m.end<float>());
  if (v.empty()) return;
  auto p99 = v.begin() + std::ptrdiff_t(v.size() * 99 / 100);
  std::nth_element(v.begin(), p99, v.end());
  const float top = std::max(*p99, 1e-6f);
  m = cv::min(m / top, 1.0);
}

// Spectral residual saliency (Hou & Zhang, CVPR 2007): the log amplitude spectrum minus its local
// average is what is "unexpected" in the image; transformed back with the original phase it
// lights up the regions that stand out.
cv::Mat spectral_residual(const cv::Mat& grey, cv::Size out_size) {
  cv::Mat small;
  cv::resize(grey, small, cv::Size(64, 64), 0, 0, cv::INTER_AREA);
  small.convertTo(small, CV_32F, 1.0 / 255);
  cv::Mat planes[] = {small, cv::Mat::zeros(small.size(), CV_32F)}, spectrum;
  cv::merge(planes, 2, spectrum);
  cv::dft(spectrum, spectrum);
  cv::split(spectrum, planes);
  cv::Mat amplitude, phase;
  cv::cartToPolar(planes[0], planes[1], amplitude, phase);
  cv::Mat log_amp, average;
  cv::log(amplitude + 1e-6f, log_amp);
  cv::blur(log_amp, average, cv::Size(3, 3));
  cv::Mat residual;
  cv::exp(log_amp - average, residual);
  cv::polarToCart(residual, phase, planes[0], planes[1]);
  cv::merge(planes, 2, spectrum);
  cv::dft(spectrum, spectrum, cv::DFT_INVERSE | cv::DFT_SCALE);
  cv::split(spectrum, planes);
  cv::Mat saliency;
  cv::magnitude(planes[0], planes[1], saliency);
  saliency = saliency.mul(saliency);
  cv::GaussianBlur(saliency, saliency, cv::Size(0, 0), 2.5);
  cv::Mat out;
  cv::resize(saliency, out, out_size, 0, 0, cv::INTER_LINEAR);
  normalise(out);
  return out;
}

cv::Mat gradient_norm(const cv::Mat& grey) {
  cv::Mat f, gx, gy, norm;
  grey.convertTo(f, CV_32F, 1.0 / 255);
  cv::GaussianBlur(f, f, cv::Size(0, 0), 1.0);  // JPEG noise is not structure
  cv::Sobel(f, gx, CV_32F, 1, 0);
  cv::Sobel(f, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, norm);
  normalise(norm);
  return norm;
}

}  // namespace

FaceCascade find_face_cascade(const std::string& configured) {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::string found = !configured.empty() && fs::is_regular_file(configured, ec) ? configured : "";
  if (found.empty() && configured == kDefaultFaceCascade) {
    const std::string name = fs::path(kDefaultFaceCascade).filename();
    for (const char* dir : {"/usr/local/share/opencv4/haarcascades", "/usr/share/opencv/haarcascades",
                            "/usr/local/share/opencv/haarcascades"})
      if (fs::is_regular_file(fs::path(dir) / name, ec)) {
        found = (fs::path(dir) / name).string();
        break;
      }
    if (found.empty()) found = cv::samples::findFile("haarcascades/" + name, false, true);
  }
  if (found.empty()) return {"", "cascade file not found"};
  cv::CascadeClassifier cascade;
  try {
    if (!cascade.load(found)) return {"", "cascade file does not load"};
  } catch (const cv::Exception&) {
    return {"", "cascade file does not load"};
  }
  return {found, ""};
}

namespace {

// The cascade at `path`, parsed once per thread (issue 28: parsing its XML cost as much as the
// detection on a small image, paid again by every image's analysis; OpenCV's classifier is not to
// be shared between threads). Null when it does not load.
cv::CascadeClassifier* loaded_cascade(const std::string& path) {
  thread_local std::unordered_map<std::string, std::unique_ptr<cv::CascadeClassifier>> loaded;
  auto [it, first] = loaded.try_emplace(path);
  if (first) {
    auto cascade = std::make_unique<cv::CascadeClassifier>();
    if (cascade->load(path)) it->second = std::move(cascade);
  }
  return it->second.get();
}

}  // namespace

std::vector<tiles::Rect> detect_faces(const tiles::Raster& image, const std::string& cascade_path) {
  std::vector<tiles::Rect> out;
  std::error_code ec;
  if (cascade_path.empty() || !std::filesystem::exists(cascade_path, ec)) return out;
  cv::CascadeClassifier* loaded = loaded_cascade(cascade_path);
  if (!loaded) return out;
  cv::CascadeClassifier& cascade = *loaded;
  // An image smaller than the cascade's window holds no face it could find (and OpenCV's
  // scaling loop is not meant for it): checked rather than left to detectMultiScale.
  const cv::Size window = cascade.getOriginalWindowSize();
  if (image.width < window.width || image.height < window.height) return out;
  cv::Mat grey = grey_of(image);
  cv::equalizeHist(grey, grey);
  std::vector<cv::Rect> faces;
  const int min_side = std::max(16, std::min(grey.cols, grey.rows) / 40);
  // 8 neighbours: fewer, surer detections (4 found "faces" in the planks of a boat).
  cascade.detectMultiScale(grey, faces, 1.1, 8, 0, cv::Size(min_side, min_side));
  for (const auto& f : faces) out.push_back({f.x, f.y, f.width, f.height});
  return out;
}

SignificanceMap compute_significance(const tiles::Raster& image, int image_width, const SignificanceOptions& options) {
  if (image.empty() || image_width < 1) throw std::invalid_argument("significance of an empty image");
  const cv::Mat grey = grey_of(image);
  cv::Mat s = gradient_norm(grey).mul(spectral_residual(grey, grey.size()));
  normalise(s);
  SignificanceMap map;
  map.width = s.cols;
  map.height = s.rows;
  map.scale = double(s.cols) / image_width;
  map.values.assign(s.begin<float>(), s.end<float>());
  paint_faces(map, faces_of(image, options));
  quantise(map);  // at the precision it is stored at (precision.h)
  return map;
}

std::vector<tiles::Rect> faces_of(const tiles::Raster& image, const SignificanceOptions& options) {
  return options.faces ? *options.faces : detect_faces(image, options.face_cascade);
}

void paint_faces(SignificanceMap& map, const std::vector<tiles::Rect>& faces) {
  cv::Mat m(map.height, map.width, CV_32F, map.values.data());
  // Faces matter whatever their texture: the whole (slightly enlarged) box is fully significant.
  for (const auto& f : faces) {
    cv::Rect box(int(f.x - f.w / 5), int(f.y - f.h / 5), int(f.w * 7 / 5), int(f.h * 7 / 5));
    m(box & cv::Rect(0, 0, m.cols, m.rows)).setTo(1.0f);
  }
}

void paint_polygon(SignificanceMap& map, const std::vector<Point>& polygon, float weight) {
  if (polygon.size() < 3) return;
  cv::Mat m(map.height, map.width, CV_32F, map.values.data());
  std::vector<cv::Point> pts;
  // fillPoly works in fixed point: 4 fractional bits keep sub-pixel vertices.
  for (const Point& p : polygon)
    pts.emplace_back(int(std::lround(p.x * map.scale * 16)), int(std::lround(p.y * map.scale * 16)));
  // The weight at the maps' precision (precision.h), as every other value of the map.
  cv::fillPoly(m, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(quantised_significance(weight)), cv::LINE_8, 4);
}

double mean_over_triangle(const SignificanceMap& map, const Point& a, const Point& b, const Point& c) {
  const Point p[3] = {{a.x * map.scale, a.y * map.scale}, {b.x * map.scale, b.y * map.scale},
                      {c.x * map.scale, c.y * map.scale}};
  const double area2 = signed_area2(p[0], p[1], p[2]);
  const int x0 = std::max(0, int(std::floor(std::min({p[0].x, p[1].x, p[2].x}))));
  const int x1 = std::min(map.width - 1, int(std::ceil(std::max({p[0].x, p[1].x, p[2].x}))));
  const int y0 = std::max(0, int(std::floor(std::min({p[0].y, p[1].y, p[2].y}))));
  const int y1 = std::min(map.height - 1, int(std::ceil(std::max({p[0].y, p[1].y, p[2].y}))));
  double sum = 0;
  int n = 0;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const Point q{x + 0.5, y + 0.5};  // pixel centre: inside when all three edge tests agree
      const double e0 = signed_area2(p[0], p[1], q), e1 = signed_area2(p[1], p[2], q), e2 = signed_area2(p[2], p[0], q);
      if ((area2 > 0 && e0 >= 0 && e1 >= 0 && e2 >= 0) || (area2 < 0 && e0 <= 0 && e1 <= 0 && e2 <= 0)) {
        sum += map.at(x, y);
        ++n;
      }
    }
  if (n > 0) return sum / n;
  const int cx = std::clamp(int((p[0].x + p[1].x + p[2].x) / 3), 0, map.width - 1);
  const int cy = std::clamp(int((p[0].y + p[1].y + p[2].y) / 3), 0, map.height - 1);
  return map.at(cx, cy);
}

std::vector<double> triangle_weights(const Mesh& mesh, const SignificanceMap& map, double w_min) {
  std::vector<double> mean(mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    mean[f] = mean_over_triangle(map, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
  }
  const auto [lo, hi] = std::minmax_element(mean.begin(), mean.end());
  const double range = mean.empty() ? 0 : *hi - *lo;
  std::vector<double> w(mean.size());
  for (std::size_t f = 0; f < mean.size(); ++f) w[f] = w_min + (1 - w_min) * (range > 0 ? (mean[f] - *lo) / range : 1.0);
  return w;
}

}  // namespace zoomwarp::warp
