#include "warp/compare/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "warp/core/triangle_locator.h"
#include "warp/core/uniform_zoom.h"

namespace zoomwarp::warp {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Inside the screen rectangle, its far edges included (a line ending on the border is seen whole).
bool on_screen(const Point& q, int sw, int sh) { return q.x >= 0 && q.y >= 0 && q.x <= sw && q.y <= sh; }

// The top tenth of the map's pixels by value, ties broken by position so that a flat map still
// gives exactly a tenth (deterministically).
std::vector<char> salient_region(const SignificanceMap& map) {
  std::vector<int> order(map.values.size());
  std::iota(order.begin(), order.end(), 0);
  const std::size_t k = (order.size() + 9) / 10;
  std::nth_element(order.begin(), order.begin() + std::ptrdiff_t(k) - (k > 0), order.end(), [&](int a, int b) {
    return map.values[a] != map.values[b] ? map.values[a] > map.values[b] : a < b;
  });
  std::vector<char> salient(order.size(), 0);
  for (std::size_t i = 0; i < k; ++i) salient[order[i]] = 1;
  return salient;
}

// What one view shows of the map: the salient region's on-screen area, and the two weighted
// means of the triangles' anisotropy.
struct MapMeasure {
  double salient_area = 0;
  double anisotropy_salient = kNaN, anisotropy_weighted = kNaN;
};

MapMeasure measure_map(const View& view, const SignificanceMap& map, const std::vector<char>& salient, int sw, int sh) {
  const Mesh& mesh = view.source;
  const TriangleLocator locator(mesh);
  std::vector<double> stretch(mesh.triangles.size(), kNaN), aniso(mesh.triangles.size(), kNaN);
  auto triangle = [&](int f) {
    if (std::isnan(stretch[f])) {
      const Triangle& t = mesh.triangles[f];
      const Point &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
      const Point &a2 = view.screen[t[0]], &b2 = view.screen[t[1]], &c2 = view.screen[t[2]];
      stretch[f] = std::abs(signed_area2(a2, b2, c2) / signed_area2(a, b, c));
      aniso[f] = anisotropy(a, b, c, a2, b2, c2);
    }
    return f;
  };
  const double pixel_area = 1 / (map.scale * map.scale);  // image px² per map pixel
  double salient_weight = 0, salient_sum = 0, mass = 0, mass_sum = 0;
  MapMeasure out;
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x) {
      const Point p{(x + 0.5) / map.scale, (y + 0.5) / map.scale};
      const MeshPoint where = locator.find(p);
      const int f = where.triangle;
      if (f < 0) continue;
      if (!on_screen(locate(mesh, view.screen, p, where), sw, sh)) continue;
      triangle(f);
      const std::size_t i = std::size_t(y) * map.width + x;
      if (salient[i]) {
        out.salient_area += pixel_area * stretch[f];
        salient_weight += pixel_area, salient_sum += pixel_area * aniso[f];
      }
      const double m = pixel_area * map.values[i];
      mass += m, mass_sum += m * aniso[f];
    }
  if (salient_weight > 0) out.anisotropy_salient = salient_sum / salient_weight;
  if (mass > 0) out.anisotropy_weighted = mass_sum / mass;
  return out;
}

// The worst line's deviation from straight on screen: each line sampled every source pixel (at
// most 4096 samples), the samples that land on screen kept in order.
std::optional<double> straightness(const View& view, const std::vector<Segment>& lines, int sw, int sh) {
  const TriangleLocator locator(view.source);
  std::optional<double> worst;
  for (const Segment& s : lines) {
    const double length = std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
    const int n = std::clamp(int(std::ceil(length)), 2, 4096);
    std::vector<Point> shown;
    for (int i = 0; i <= n; ++i) {
      const double u = double(i) / n;
      const Point p{s.a.x + u * (s.b.x - s.a.x), s.a.y + u * (s.b.y - s.a.y)};
      const MeshPoint where = locator.find(p);
      if (where.triangle < 0) continue;
      const Point q = locate(view.source, view.screen, p, where);
      if (on_screen(q, sw, sh)) shown.push_back(q);
    }
    if (shown.size() >= 2) worst = std::max(worst.value_or(0.0), chord_deviation(shown));
  }
  return worst;
}

}  // namespace

double anisotropy(const Point& a, const Point& b, const Point& c, const Point& a2, const Point& b2, const Point& c2) {
  // The affine map's linear part M solves M·[b−a, c−a] = [b'−a', c'−a'].
  const double e11 = b.x - a.x, e12 = c.x - a.x, e21 = b.y - a.y, e22 = c.y - a.y;
  const double f11 = b2.x - a2.x, f12 = c2.x - a2.x, f21 = b2.y - a2.y, f22 = c2.y - a2.y;
  const double det = e11 * e22 - e12 * e21;
  if (det == 0) return kNaN;
  const double m11 = (f11 * e22 - f12 * e21) / det, m12 = (f12 * e11 - f11 * e12) / det;
  const double m21 = (f21 * e22 - f22 * e21) / det, m22 = (f22 * e11 - f21 * e12) / det;
  // Singular values of a 2×2 matrix: σ1² + σ2² = ‖M‖_F², σ1·σ2 = |det M|.
  const double fro = m11 * m11 + m12 * m12 + m21 * m21 + m22 * m22, dm = std::abs(m11 * m22 - m12 * m21);
  const double s1 = std::sqrt((fro + std::sqrt(std::max(0.0, fro * fro - 4 * dm * dm))) / 2);
  if (dm == 0) return std::numeric_limits<double>::infinity();
  return s1 * s1 / dm;  // σ1/σ2 = σ1² / (σ1·σ2)
}

int fold_count(const View& view) {
  int folds = 0;
  for (int f : view.visible) {
    const Triangle& t = view.source.triangles[f];
    if (signed_area2(view.screen[t[0]], view.screen[t[1]], view.screen[t[2]]) <= 0) ++folds;
  }
  return folds;
}

double coverage(const View& view, int sw, int sh) {
  if (sw <= 0 || sh <= 0) return 0;
  std::vector<char> covered(std::size_t(sw) * sh, 0);
  for (int f : view.visible) {
    const Triangle& t = view.source.triangles[f];
    const Point &a = view.screen[t[0]], &b = view.screen[t[1]], &c = view.screen[t[2]];
    const double area = signed_area2(a, b, c);
    if (area == 0) continue;
    // A pixel centre on a shared edge is in both triangles: the edge tests include 0, with a
    // tolerance relative to the edge length so that rounding leaves no crack.
    const double eps = 1e-9 * std::abs(area);
    const int x0 = std::max(0, int(std::floor(std::min({a.x, b.x, c.x}) - 0.5)));
    const int x1 = std::min(sw - 1, int(std::ceil(std::max({a.x, b.x, c.x}) - 0.5)));
    const int y0 = std::max(0, int(std::floor(std::min({a.y, b.y, c.y}) - 0.5)));
    const int y1 = std::min(sh - 1, int(std::ceil(std::max({a.y, b.y, c.y}) - 0.5)));
    const double sign = area > 0 ? 1 : -1;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const Point p{x + 0.5, y + 0.5};
        if (sign * signed_area2(p, b, c) >= -eps && sign * signed_area2(a, p, c) >= -eps &&
            sign * signed_area2(a, b, p) >= -eps)
          covered[std::size_t(y) * sw + x] = 1;
      }
  }
  return double(std::count(covered.begin(), covered.end(), 1)) / covered.size();
}

double chord_deviation(const std::vector<Point>& points) {
  if (points.size() < 3) return 0;
  const Point &a = points.front(), &b = points.back();
  const double length = std::hypot(b.x - a.x, b.y - a.y);
  double worst = 0;
  for (const Point& p : points)
    worst = std::max(worst, length > 0 ? std::abs(signed_area2(a, b, p)) / length : std::hypot(p.x - a.x, p.y - a.y));
  return worst;
}

// [Umeyama 1991] in 2D: with centred X, Y, the best rotation-and-scale sR (det R = +1) has
// s·cos θ = Σ X·Y / Σ|X|² and s·sin θ = Σ X×Y / Σ|X|². The residual is summed point by point:
// Σ|Y|² − s²Σ|X|² would lose it to cancellation when it is small.
double similarity_fit_residual(const std::vector<Point>& from, const std::vector<Point>& to) {
  const std::size_t n = from.size();
  if (n < 2 || to.size() != n) return kNaN;
  Point mf, mt;
  for (std::size_t i = 0; i < n; ++i) mf.x += from[i].x / n, mf.y += from[i].y / n, mt.x += to[i].x / n, mt.y += to[i].y / n;
  double xx = 0, dot = 0, cross = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double x1 = from[i].x - mf.x, x2 = from[i].y - mf.y, y1 = to[i].x - mt.x, y2 = to[i].y - mt.y;
    xx += x1 * x1 + x2 * x2;
    dot += x1 * y1 + x2 * y2, cross += x1 * y2 - x2 * y1;
  }
  if (xx == 0) return kNaN;
  const double sc = dot / xx, ss = cross / xx, s = std::hypot(sc, ss);
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double x1 = from[i].x - mf.x, x2 = from[i].y - mf.y;
    sum += std::pow(to[i].x - mt.x - (sc * x1 - ss * x2), 2) + std::pow(to[i].y - mt.y - (ss * x1 + sc * x2), 2);
  }
  const double residual = std::sqrt(sum / n);
  if (s == 0) return residual > 0 ? std::numeric_limits<double>::infinity() : 0;
  return residual / (s * std::sqrt(xx / n));
}

ViewMetrics mesh_view_metrics(const View& view, const View& traditional, const SignificanceMap& significance,
                              const std::vector<Segment>& lines, int sw, int sh) {
  ViewMetrics out;
  out.folds = fold_count(view);
  out.coverage = coverage(view, sw, sh);
  out.straightness = straightness(view, lines, sw, sh);
  if (significance.values.empty()) return out;
  const std::vector<char> salient = salient_region(significance);
  const MapMeasure shown = measure_map(view, significance, salient, sw, sh);
  const MapMeasure reference = measure_map(traditional, significance, salient, sw, sh);
  if (reference.salient_area > 0) out.scale_gain = shown.salient_area / reference.salient_area;
  if (!std::isnan(shown.anisotropy_salient)) out.anisotropy_salient = shown.anisotropy_salient;
  if (!std::isnan(shown.anisotropy_weighted)) out.anisotropy_weighted = shown.anisotropy_weighted;
  return out;
}

namespace {

// Whether image point p lies in the salient region (the map pixel holding it is salient).
bool in_salient(const Point& p, const SignificanceMap& map, const std::vector<char>& salient) {
  if (!(p.x >= 0 && p.y >= 0)) return false;  // NaN too
  const int x = int(p.x * map.scale), y = int(p.y * map.scale);
  return x < map.width && y < map.height && salient[std::size_t(y) * map.width + x];
}

// Screen pixels of traditional zoom (a uniform scale of the image, view.geometry.screen_scale,
// its origin at view_x, view_y) that show the salient region.
std::size_t traditional_salient_pixels(const View& v, int sw, int sh, const SignificanceMap& map,
                                       const std::vector<char>& salient) {
  const double scale = v.geometry.screen_scale;
  std::size_t n = 0;
  for (int y = 0; y < sh; ++y)
    for (int x = 0; x < sw; ++x)
      n += in_salient({v.view_x + (x + 0.5) / scale, v.view_y + (y + 0.5) / scale}, map, salient);
  return n;
}

}  // namespace

ViewMetrics raster_view_metrics(const tiles::Raster& screen, const std::vector<Point>& sources, const View& traditional,
                                const SignificanceMap& significance) {
  ViewMetrics out;
  if (!sources.empty() && sources.size() == std::size_t(screen.width) * screen.height && !significance.values.empty()) {
    const std::vector<char> salient = salient_region(significance);
    std::size_t shown = 0;
    for (const Point& p : sources) shown += in_salient(p, significance, salient);
    const std::size_t reference = traditional_salient_pixels(traditional, screen.width, screen.height, significance, salient);
    if (reference > 0) out.scale_gain = double(shown) / double(reference);
  }
  const std::size_t pixels = std::size_t(screen.width) * screen.height;
  if (pixels == 0) return out;
  if (sources.size() == pixels) {
    // What is drawn where, exactly: black or transparent image content counts as covered.
    out.coverage = double(std::count_if(sources.begin(), sources.end(), [](const Point& p) { return p.x == p.x; })) / pixels;
    return out;
  }
  const bool alpha = screen.channels == 2 || screen.channels == 4;
  std::size_t covered = 0;
  for (int y = 0; y < screen.height; ++y) {
    const auto* row = screen.row(y);
    for (int x = 0; x < screen.width; ++x) {
      const auto* px = row + std::size_t(x) * screen.channels;
      if (alpha ? px[screen.channels - 1] != 0 : std::any_of(px, px + screen.channels, [](auto v) { return v != 0; }))
        ++covered;
    }
  }
  out.coverage = double(covered) / pixels;
  return out;
}

}  // namespace zoomwarp::warp
