#include "warp/lines/line_detection.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "warp/core/limits.h"

namespace zoomwarp::warp {

namespace {

// Below this the 5×5 blur and the Hough accumulator see too few pixels to tell a line from noise.
constexpr int kMinSide = 32;
// Canny's hysteresis thresholds on the L2 Sobel magnitude: a step of about 20 grey levels after
// the blur starts an edge (ours; [Guo09] gives none).
constexpr double kCannyLow = 30, kCannyHigh = 90;
// A segment whose ends both lie this close to one side of the image runs along the border.
constexpr double kBorderMargin = 2;
// The edge test of a Hough segment (ours): at least this share of its samples must have a
// gradient across it — at least kCannyLow, within kAcrossDegrees of its normal.
constexpr double kMinAcrossShare = 0.75;
constexpr double kAcrossDegrees = 22.5;

double length(const Segment& s) { return std::hypot(s.b.x - s.a.x, s.b.y - s.a.y); }

cv::Mat grey_of(const tiles::Raster& image) {
  const cv::Mat in(image.height, image.width, CV_8UC(image.channels), const_cast<std::uint8_t*>(image.pixels.data()));
  cv::Mat grey;
  if (image.channels <= 2) cv::extractChannel(in, grey, 0);  // grey or grey + alpha
  else cv::cvtColor(in, grey, image.channels == 4 ? cv::COLOR_RGBA2GRAY : cv::COLOR_RGB2GRAY);
  return grey;
}

// Unit direction of s and its line's distance to p.
struct Line {
  Point origin, dir;
  explicit Line(const Segment& s) : origin(s.a) {
    const double l = length(s);
    dir = {(s.b.x - s.a.x) / l, (s.b.y - s.a.y) / l};
  }
  double along(const Point& p) const { return (p.x - origin.x) * dir.x + (p.y - origin.y) * dir.y; }
  double distance(const Point& p) const { return std::abs((p.x - origin.x) * dir.y - (p.y - origin.y) * dir.x); }
  Point at(double t) const { return {origin.x + t * dir.x, origin.y + t * dir.y}; }
};

// [Guo09 §3.3.3] "Only one segment is reserved if several segments are close enough": when
// `shorter` lies along `longer`, `longer` becomes the span of both along its own line (ours:
// Hough splits one long edge into pieces at its angular resolution, and the span is that edge).
// Returns whether it merged.
bool merge_into(Segment& longer, const Segment& shorter, double max_angle, double max_offset) {
  if (!lies_along(shorter, longer, max_offset, max_angle)) return false;
  const Line line(longer);
  const double s0 = std::min(line.along(shorter.a), line.along(shorter.b));
  const double s1 = std::max(line.along(shorter.a), line.along(shorter.b));
  longer = {line.at(std::min(0.0, s0)), line.at(std::max(length(longer), s1))};
  return true;
}

bool along_border(const Segment& s, double w, double h) {
  const auto near = [](double a, double b, double edge) {
    return std::abs(a - edge) <= kBorderMargin && std::abs(b - edge) <= kBorderMargin;
  };
  return near(s.a.x, s.b.x, 0) || near(s.a.x, s.b.x, w - 1) || near(s.a.y, s.b.y, 0) || near(s.a.y, s.b.y, h - 1);
}

// Whether the image has an edge along s (ours). HoughLinesP only counts edge pixels on a line:
// where Canny marks texture or noise densely (gravel, foliage, sensor noise), straight runs of
// such pixels cross it in every direction, and nothing in the vote says they are one edge. An
// edge has its gradient across the segment all along it; noise has it in random directions.
// Each pixel step along s looks at the pixels up to 1 px to either side (Hough's end points are
// whole pixels) for one whose gradient is strong and within kAcrossDegrees of s's normal.
bool is_edge(const Segment& s, const cv::Mat& gx, const cv::Mat& gy) {
  const double l = length(s);
  const double nx = -(s.b.y - s.a.y) / l, ny = (s.b.x - s.a.x) / l;
  const double min_cos = std::cos(kAcrossDegrees * std::numbers::pi / 180);
  const int steps = int(l);
  int across = 0;
  for (int i = 0; i <= steps; ++i) {
    const double t = steps == 0 ? 0 : double(i) / steps;
    bool found = false;
    for (int side = -1; side <= 1 && !found; ++side) {
      const int x = int(std::lround(s.a.x + t * (s.b.x - s.a.x) + side * nx));
      const int y = int(std::lround(s.a.y + t * (s.b.y - s.a.y) + side * ny));
      if (x < 0 || y < 0 || x >= gx.cols || y >= gx.rows) continue;
      const double g_x = gx.at<float>(y, x), g_y = gy.at<float>(y, x);
      const double normal = std::abs(g_x * nx + g_y * ny);
      found = normal >= kCannyLow && normal >= min_cos * std::hypot(g_x, g_y);
    }
    across += found;
  }
  return across >= kMinAcrossShare * (steps + 1);
}

// s refitted to the edge pixels it stands for (ours): Hough's end points are pixels its walk
// happened to stop at, and on a short piece of a tilted edge's staircase its angle can be off by
// degrees — too far for the duplicate test to join the pieces again. The line through the Canny
// pixels within 2 px of s (total least squares), twice, from the first to the last of them.
Segment refit(Segment s, const cv::Mat& edges) {
  for (int round = 0; round < 2; ++round) {
    const Line line(s);
    const double l = length(s);
    std::vector<cv::Point> pixels;
    for (int i = -2; i <= int(l) + 2; ++i)
      for (int k = -2; k <= 2; ++k) {
        const int x = int(std::lround(s.a.x + i * line.dir.x - k * line.dir.y));
        const int y = int(std::lround(s.a.y + i * line.dir.y + k * line.dir.x));
        if (x >= 0 && y >= 0 && x < edges.cols && y < edges.rows && edges.at<std::uint8_t>(y, x))
          pixels.push_back({x, y});
      }
    std::sort(pixels.begin(), pixels.end(), [](cv::Point a, cv::Point b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
    pixels.erase(std::unique(pixels.begin(), pixels.end()), pixels.end());
    if (pixels.size() < 2) return s;
    cv::Vec4f fit;
    cv::fitLine(pixels, fit, cv::DIST_L2, 0, 0.01, 0.01);
    const Line fitted(Segment{{fit[2], fit[3]}, {fit[2] + fit[0], fit[3] + fit[1]}});
    double lo = INFINITY, hi = -INFINITY;
    for (const cv::Point& p : pixels) {
      const double t = fitted.along({double(p.x), double(p.y)});
      lo = std::min(lo, t), hi = std::max(hi, t);
    }
    s = {fitted.at(lo), fitted.at(hi)};
    if (length(s) == 0) return s;
  }
  return s;
}

// Merges near-duplicates, longest first, until no pair merges (a merge lengthens a segment,
// which may then reach another).
std::vector<Segment> merge_duplicates(std::vector<Segment> segments, double max_angle, double max_offset) {
  for (bool merged = true; merged;) {
    merged = false;
    std::sort(segments.begin(), segments.end(), [](const Segment& a, const Segment& b) { return length(a) > length(b); });
    std::vector<Segment> kept;
    for (const Segment& s : segments) {
      const bool absorbed = std::any_of(kept.begin(), kept.end(),
                                        [&](Segment& k) { return merge_into(k, s, max_angle, max_offset); });
      merged = merged || absorbed;
      if (!absorbed) kept.push_back(s);
    }
    segments = std::move(kept);
  }
  return segments;
}

}  // namespace

std::vector<Segment> detect_lines(const tiles::Raster& analysis, double image_width, double image_height,
                                  const LineDetectionOptions& options) {
  const int wa = analysis.width, ha = analysis.height;
  if (wa < kMinSide || ha < kMinSide || analysis.channels < 1 || analysis.channels > 4 ||
      analysis.pixels.size() != std::size_t(wa) * ha * analysis.channels || !(image_width > 0 && image_height > 0))
    return {};
  cv::Mat grey = grey_of(analysis), edges;
  cv::GaussianBlur(grey, grey, cv::Size(5, 5), 0);
  cv::Canny(grey, edges, kCannyLow, kCannyHigh, 3, /*L2gradient=*/true);

  const double min_length = std::max(options.min_length_fraction * std::min(wa, ha), options.min_length_floor);
  // Hough walks along its quantised angle (half-degree bins), which drifts off a long or slightly
  // tilted edge's staircase of pixels and splits it into pieces: pieces down to a quarter of L
  // are kept here, checked one by one, merged into their edge below, and only then held to L.
  const double min_piece = min_length / 4;
  std::vector<cv::Vec4i> found;
  cv::HoughLinesP(edges, found, 1, std::numbers::pi / 360, std::max(int(min_piece), 5), min_piece, 3);

  cv::Mat gx, gy;
  cv::Sobel(grey, gx, CV_32F, 1, 0, 3);  // the gradient Canny's thresholds are on
  cv::Sobel(grey, gy, CV_32F, 0, 1, 3);
  std::vector<Segment> segments;
  for (const cv::Vec4i& f : found) {
    const Segment s = refit({{double(f[0]), double(f[1])}, {double(f[2]), double(f[3])}}, edges);
    if (length(s) > 0 && is_edge(s, gx, gy)) segments.push_back(s);
  }
  const double d = std::sqrt(double(wa) * ha / options.point_count);
  segments = merge_duplicates(std::move(segments), options.duplicate_angle_degrees * std::numbers::pi / 180, d / 2);

  // Analysis pixel centres to image pixels, longest first within the curator's limits.
  const double sx = image_width / wa, sy = image_height / ha;
  const double max_total = limits::kMaxTotalLineLength * std::max(image_width, image_height);
  const auto to_image = [&](const Point& p) {
    return Point{std::clamp((p.x + 0.5) * sx, 0.0, image_width), std::clamp((p.y + 0.5) * sy, 0.0, image_height)};
  };
  std::vector<Segment> out;
  double total = 0;
  for (const Segment& s : segments) {
    // A merged edge is checked whole again: pieces of texture that line up by chance leave gaps.
    if (length(s) < min_length || along_border(s, wa, ha) || !is_edge(s, gx, gy)) continue;
    const Segment scaled{to_image(s.a), to_image(s.b)};
    if (total + length(scaled) > max_total) continue;
    total += length(scaled);
    out.push_back(scaled);
    if (out.size() == std::size_t(limits::kMaxLines)) break;
  }
  return out;
}

bool lies_along(const Segment& s, const Segment& line_segment, double max_offset, double max_angle) {
  if (length(s) == 0 || length(line_segment) == 0) return false;
  const Line line(line_segment), other(s);
  if (std::abs(line.dir.x * other.dir.x + line.dir.y * other.dir.y) < std::cos(max_angle)) return false;
  if (line.distance(s.a) > max_offset || line.distance(s.b) > max_offset) return false;
  const double s0 = std::min(line.along(s.a), line.along(s.b)), s1 = std::max(line.along(s.a), line.along(s.b));
  return s0 <= length(line_segment) + max_offset && s1 >= -max_offset;
}

std::vector<Segment> clear_pieces(const Segment& s, const std::vector<Segment>& others, double clearance,
                                  double min_length) {
  const auto distance = [](const Point& p, const Segment& t) {
    const double dx = t.b.x - t.a.x, dy = t.b.y - t.a.y, l2 = dx * dx + dy * dy;
    const double u = l2 > 0 ? std::clamp(((p.x - t.a.x) * dx + (p.y - t.a.y) * dy) / l2, 0.0, 1.0) : 0;
    return std::hypot(p.x - t.a.x - u * dx, p.y - t.a.y - u * dy);
  };
  // Samples about a pixel apart (at most 4096: a line is at most one image side long).
  const int steps = std::clamp(int(std::ceil(length(s))), 1, 4096);
  const auto at = [&](int i) {
    const double t = double(i) / steps;
    return Point{s.a.x + t * (s.b.x - s.a.x), s.a.y + t * (s.b.y - s.a.y)};
  };
  std::vector<Segment> pieces;
  int run_start = -1;
  for (int i = 0; i <= steps + 1; ++i) {
    const bool clear = i <= steps && std::none_of(others.begin(), others.end(), [&](const Segment& t) {
      return distance(at(i), t) < clearance;
    });
    if (clear && run_start < 0) run_start = i;
    if (!clear && run_start >= 0) {
      const Segment piece{at(run_start), at(i - 1)};
      if (length(piece) >= min_length) pieces.push_back(piece);
      run_start = -1;
    }
  }
  return pieces;
}

bool same_segment(const Segment& a, const Segment& b, double tolerance) {
  const auto near = [&](const Point& p, const Point& q) { return std::hypot(p.x - q.x, p.y - q.y) <= tolerance; };
  return (near(a.a, b.a) && near(a.b, b.b)) || (near(a.a, b.b) && near(a.b, b.a));
}

std::vector<Segment> remaining_suggestions(const std::vector<Segment>& detected, const std::vector<Segment>& curator,
                                           const std::vector<Segment>& dismissed, double image_width,
                                           double image_height, const LineDetectionOptions& options) {
  const double max_offset = std::sqrt(image_width * image_height / options.point_count) / 2;
  const double max_angle = options.duplicate_angle_degrees * std::numbers::pi / 180;
  std::vector<Segment> out;
  for (const Segment& s : detected) {
    const bool was_dismissed = std::any_of(dismissed.begin(), dismissed.end(),
                                           [&](const Segment& t) { return same_segment(s, t, kSameSegmentTolerance); });
    const bool curated = std::any_of(curator.begin(), curator.end(),
                                     [&](const Segment& t) { return lies_along(s, t, max_offset, max_angle); });
    if (!was_dismissed && !curated) out.push_back(s);
  }
  return out;
}

}  // namespace zoomwarp::warp
