#include "warp/compare/metrics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include "warp/core/segment_pieces.h"
#include "warp/core/uniform_zoom.h"

namespace zoomwarp::warp {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Inside the screen rectangle, its far edges included (a line ending on the border is seen whole).
bool on_screen(const Point& q, int sw, int sh) { return q.x >= 0 && q.y >= 0 && q.x <= sw && q.y <= sh; }

// The top 1/`parts` of the map's pixels by value, ties broken by position so that a flat map still
// gives exactly that share (deterministically): the salient region of the gain (a tenth) and of
// the squash measures (a fifth).
std::vector<char> top_share(const SignificanceMap& map, std::size_t parts) {
  std::vector<int> order(map.values.size());
  std::iota(order.begin(), order.end(), 0);
  const std::size_t k = (order.size() + parts - 1) / parts;
  std::nth_element(order.begin(), order.begin() + std::ptrdiff_t(k) - (k > 0), order.end(), [&](int a, int b) {
    return map.values[a] != map.values[b] ? map.values[a] > map.values[b] : a < b;
  });
  std::vector<char> salient(order.size(), 0);
  for (std::size_t i = 0; i < k; ++i) salient[order[i]] = 1;
  return salient;
}

std::vector<char> salient_region(const SignificanceMap& map) { return top_share(map, 10); }
std::vector<char> top_fifth(const SignificanceMap& map) { return top_share(map, 5); }

// Whether map pixel (x, y)'s centre, held by triangle f of the view's source mesh, lands on the
// screen (its far edges included).
bool lands_on_screen(const View& view, const SignificanceMap& map, int x, int y, int f, int sw, int sh) {
  const Mesh& mesh = view.source;
  const Point p{(x + 0.5) / map.scale, (y + 0.5) / map.scale};
  const Triangle& t = mesh.triangles[f];
  const MeshPoint where{f, barycentric(p, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]])};
  return on_screen(locate(mesh, view.screen, p, where), sw, sh);
}

// The linear part M = [m11 m12; m21 m22] of the affine map taking triangle (a, b, c) to
// (a', b', c'): M·[b−a, c−a] = [b'−a', c'−a']. None for a degenerate source triangle.
std::optional<std::array<double, 4>> linear_part(const Point& a, const Point& b, const Point& c, const Point& a2,
                                                 const Point& b2, const Point& c2) {
  const double e11 = b.x - a.x, e12 = c.x - a.x, e21 = b.y - a.y, e22 = c.y - a.y;
  const double f11 = b2.x - a2.x, f12 = c2.x - a2.x, f21 = b2.y - a2.y, f22 = c2.y - a2.y;
  const double det = e11 * e22 - e12 * e21;
  if (det == 0) return std::nullopt;
  return std::array<double, 4>{(f11 * e22 - f12 * e21) / det, (f12 * e11 - f11 * e12) / det,
                               (f21 * e22 - f22 * e21) / det, (f22 * e11 - f21 * e12) / det};
}

// What one view shows of the map: the salient region's on-screen area, the two weighted means of
// the triangles' anisotropy, and per triangle the weights of the rotation statistics.
struct MapMeasure {
  double salient_area = 0;
  double anisotropy_salient = kNaN, anisotropy_weighted = kNaN;
  std::vector<double> salient_screen_area, mass;  // per triangle, on screen
};

MapMeasure measure_map(const View& view, const SignificanceMap& map, const std::vector<char>& salient, int sw, int sh) {
  const Mesh& mesh = view.source;
  const std::vector<int> holder = map_pixel_triangles(mesh, map.width, map.height, map.scale);
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
  out.salient_screen_area.assign(mesh.triangles.size(), 0);
  out.mass.assign(mesh.triangles.size(), 0);
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x) {
      const std::size_t i = std::size_t(y) * map.width + x;
      const int f = holder[i];
      if (f < 0 || !lands_on_screen(view, map, x, y, f, sw, sh)) continue;
      triangle(f);
      if (salient[i]) {
        out.salient_area += pixel_area * stretch[f];
        out.salient_screen_area[f] += pixel_area * stretch[f];
        salient_weight += pixel_area, salient_sum += pixel_area * aniso[f];
      }
      const double m = pixel_area * map.values[i];
      mass += m, mass_sum += m * aniso[f];
      out.mass[f] += m;
    }
  if (salient_weight > 0) out.anisotropy_salient = salient_sum / salient_weight;
  if (mass > 0) out.anisotropy_weighted = mass_sum / mass;
  return out;
}

// rotation_p95 and rotation_spread (metrics.h) from a view's per-triangle weights.
void rotation_statistics(const View& view, const MapMeasure& shown, ViewMetrics& out) {
  const Mesh& mesh = view.source;
  std::vector<Weighted> magnitude, turn;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (shown.salient_screen_area[f] == 0 && shown.mass[f] == 0) continue;
    const Triangle& t = mesh.triangles[f];
    const double theta = rotation_degrees(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]],
                                          view.screen[t[0]], view.screen[t[1]], view.screen[t[2]]);
    if (std::isnan(theta)) continue;
    if (shown.salient_screen_area[f] > 0) magnitude.push_back({std::abs(theta), shown.salient_screen_area[f]});
    if (shown.mass[f] > 0) turn.push_back({theta, shown.mass[f]});
  }
  const double p95 = weighted_quantile(std::move(magnitude), 0.95), spread = weighted_spread(turn);
  if (!std::isnan(p95)) out.rotation_p95 = p95;
  if (!std::isnan(spread)) out.rotation_spread = spread;
}

// The worst bend of the lines whose chord on screen is at least kMinMeasuredLinePx, and their count.
void straightness(const View& view, const std::vector<Segment>& lines, int sw, int sh, ViewMetrics& out) {
  out.lines_measured = 0;
  for (const Segment& s : lines) {
    const std::optional<LineBend> bend = line_bend(view, s, sw, sh);
    if (!bend || bend->chord < kMinMeasuredLinePx) continue;
    ++*out.lines_measured;
    out.straightness = std::max(out.straightness.value_or(0.0), bend->deviation);
  }
}

// The parameter interval [lo, hi] ⊆ [0, 1] of p + u·d inside the box [x0, x1] × [y0, y1]
// (Liang–Barsky); false when empty.
bool clip_to_box(const Point& p, const Point& d, double x0, double y0, double x1, double y1, double& lo, double& hi) {
  const double q[4][2] = {{-d.x, p.x - x0}, {d.x, x1 - p.x}, {-d.y, p.y - y0}, {d.y, y1 - p.y}};
  for (const auto& [step, room] : q) {
    if (step == 0) {
      if (room < 0) return false;
    } else if (step < 0) {
      lo = std::max(lo, room / step);
    } else {
      hi = std::min(hi, room / step);
    }
  }
  return lo <= hi;
}

}  // namespace

double anisotropy(const Point& a, const Point& b, const Point& c, const Point& a2, const Point& b2, const Point& c2) {
  const auto m = linear_part(a, b, c, a2, b2, c2);
  if (!m) return kNaN;
  const auto [m11, m12, m21, m22] = *m;
  // Singular values of a 2×2 matrix: σ1² + σ2² = ‖M‖_F², σ1·σ2 = |det M|.
  const double fro = m11 * m11 + m12 * m12 + m21 * m21 + m22 * m22, dm = std::abs(m11 * m22 - m12 * m21);
  const double s1 = std::sqrt((fro + std::sqrt(std::max(0.0, fro * fro - 4 * dm * dm))) / 2);
  if (dm == 0) return std::numeric_limits<double>::infinity();
  return s1 * s1 / dm;  // σ1/σ2 = σ1² / (σ1·σ2)
}

// The polar decomposition M = R·S (R a rotation, S symmetric) of a 2×2 M has R's angle
// atan2(m21 − m12, m11 + m22): the rotation maximising tr(Rᵀ M) = cos θ (m11 + m22) +
// sin θ (m21 − m12) is the closest to M in the Frobenius norm.
double rotation_degrees(const Point& a, const Point& b, const Point& c, const Point& a2, const Point& b2,
                        const Point& c2) {
  const auto m = linear_part(a, b, c, a2, b2, c2);
  if (!m) return kNaN;
  const auto [m11, m12, m21, m22] = *m;
  return std::atan2(m21 - m12, m11 + m22) * 180 / std::numbers::pi;
}

double weighted_quantile(std::vector<Weighted> values, double q) {
  std::sort(values.begin(), values.end(), [](const Weighted& a, const Weighted& b) { return a.value < b.value; });
  double total = 0;
  for (const Weighted& v : values) total += v.weight;
  if (!(total > 0)) return kNaN;
  double sum = 0;
  for (const Weighted& v : values) {
    sum += v.weight;
    if (sum >= q * total) return v.value;
  }
  return values.back().value;  // q × total not reached by rounding
}

double weighted_spread(const std::vector<Weighted>& values) {
  double total = 0, mean = 0;
  for (const Weighted& v : values) total += v.weight, mean += v.weight * v.value;
  if (!(total > 0)) return kNaN;
  mean /= total;
  double variance = 0;
  for (const Weighted& v : values) variance += v.weight * (v.value - mean) * (v.value - mean);
  return std::sqrt(variance / total);
}

// Each triangle, in mesh order, visits the centres in its bounding box (one pixel wider, which
// holds every centre within kOnEdge of it): a centre takes the first triangle that holds it
// (smallest coordinate ≥ 0) and, until one does, the first of those that come nearest — the
// order and the comparisons of locate_in's scan, over the only triangles that can matter.
std::vector<int> map_pixel_triangles(const Mesh& mesh, int width, int height, double scale) {
  const std::size_t n = std::size_t(std::max(width, 0)) * std::max(height, 0);
  std::vector<int> holder(n, -1);
  std::vector<double> best(n, -std::numeric_limits<double>::infinity());
  for (int f = 0; f < int(mesh.triangles.size()); ++f) {
    const Triangle& t = mesh.triangles[f];
    const Point &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    if (signed_area2(a, b, c) == 0) continue;  // no coordinates: locate_in's NaN never wins
    // Centre x + 0.5 = X · scale for X in the box.
    const int x0 = std::max(0, int(std::floor(std::min({a.x, b.x, c.x}) * scale - 0.5)) - 1);
    const int x1 = std::min(width - 1, int(std::ceil(std::max({a.x, b.x, c.x}) * scale - 0.5)) + 1);
    const int y0 = std::max(0, int(std::floor(std::min({a.y, b.y, c.y}) * scale - 0.5)) - 1);
    const int y1 = std::min(height - 1, int(std::ceil(std::max({a.y, b.y, c.y}) * scale - 0.5)) + 1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const std::size_t i = std::size_t(y) * width + x;
        if (best[i] >= 0) continue;
        const auto l = barycentric({(x + 0.5) / scale, (y + 0.5) / scale}, a, b, c);
        const double inside = std::min({l[0], l[1], l[2]});
        if (inside > best[i]) best[i] = inside, holder[i] = f;
      }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (best[i] < kOnEdge) holder[i] = -1;
  return holder;
}

// The line's screen image is affine within each visible triangle: its piece there
// (segment_pieces) maps to a straight segment, which is cut to the screen. The polyline through
// the kept pieces' ends, in order of u, is the line on screen; its farthest point from a line is
// one of those ends.
std::optional<LineBend> line_bend(const View& view, const Segment& s, int sw, int sh) {
  const Mesh& mesh = view.source;
  std::vector<std::pair<double, Point>> shown;  // (u, screen point)
  for (const SegmentPiece& piece : segment_pieces(mesh, s, view.visible)) {
    const double lo = piece.lo, hi = piece.hi;
    auto screen_at = [&](double u) {
      const Point p{s.a.x + u * (s.b.x - s.a.x), s.a.y + u * (s.b.y - s.a.y)};
      return locate(mesh, view.screen, p, piece_point(mesh, s, piece, u));
    };
    const Point q0 = screen_at(lo), q1 = screen_at(hi);
    double v0 = 0, v1 = 1;  // the screen segment q0 + v·(q1 − q0) cut to the screen
    if (!clip_to_box(q0, {q1.x - q0.x, q1.y - q0.y}, 0, 0, sw, sh, v0, v1)) continue;
    for (double v : {v0, v1})
      shown.push_back({lo + v * (hi - lo), {q0.x + v * (q1.x - q0.x), q0.y + v * (q1.y - q0.y)}});
  }
  if (shown.empty()) return std::nullopt;
  std::sort(shown.begin(), shown.end(), [](const auto& p, const auto& q) { return p.first < q.first; });
  std::vector<Point> polyline;
  for (const auto& [u, q] : shown) polyline.push_back(q);
  const Point &first = polyline.front(), &last = polyline.back();
  return LineBend{chord_deviation(polyline), std::hypot(last.x - first.x, last.y - first.y)};
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
  straightness(view, lines, sw, sh, out);
  if (significance.values.empty()) return out;
  const std::vector<char> salient = salient_region(significance);
  const MapMeasure shown = measure_map(view, significance, salient, sw, sh);
  const MapMeasure reference = measure_map(traditional, significance, salient, sw, sh);
  if (reference.salient_area > 0) out.scale_gain = shown.salient_area / reference.salient_area;
  rotation_statistics(view, shown, out);
  if (!std::isnan(shown.anisotropy_salient)) out.anisotropy_salient = shown.anisotropy_salient;
  if (!std::isnan(shown.anisotropy_weighted)) out.anisotropy_weighted = shown.anisotropy_weighted;
  out.squash = squash_measures(view, significance, sw, sh);
  return out;
}

SquashMeasures squash_measures(const View& view, const SignificanceMap& map, int sw, int sh) {
  SquashMeasures out;
  if (map.values.empty()) return out;
  const Mesh& mesh = view.source;
  const std::vector<char> salient = top_fifth(map);
  const std::vector<int> holder = map_pixel_triangles(mesh, map.width, map.height, map.scale);
  std::vector<double> aniso(mesh.triangles.size(), kNaN), shown;
  double mass = 0, mass_shown = 0;
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x) {
      const std::size_t i = std::size_t(y) * map.width + x;
      if (!salient[i]) continue;
      mass += map.values[i];
      const int f = holder[i];
      if (f < 0 || !lands_on_screen(view, map, x, y, f, sw, sh)) continue;
      const Triangle& t = mesh.triangles[f];
      if (std::isnan(aniso[f]))
        aniso[f] = anisotropy(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], view.screen[t[0]],
                              view.screen[t[1]], view.screen[t[2]]);
      mass_shown += map.values[i];
      shown.push_back(aniso[f]);
    }
  out.coverage = mass > 0 ? mass_shown / mass : 1.0;
  if (!shown.empty()) {
    std::vector<Weighted> weighted;
    for (double a : shown) weighted.push_back({a, 1});
    out.anisotropy_p90 = weighted_quantile(weighted, 0.90);
    out.anisotropy_p99 = weighted_quantile(weighted, 0.99);
  }
  return out;
}

SquashMeasures squash_measures_of_sources(const std::vector<Point>& sources, const SignificanceMap& map) {
  SquashMeasures out;
  if (map.values.empty()) return out;
  const std::vector<char> salient = top_fifth(map);
  std::vector<char> seen(map.values.size(), 0);
  for (const Point& p : sources) {
    if (!(p.x >= 0 && p.y >= 0)) continue;  // NaN: nothing shown there
    const int x = int(p.x * map.scale), y = int(p.y * map.scale);
    if (x < map.width && y < map.height) seen[std::size_t(y) * map.width + x] = 1;
  }
  double mass = 0, mass_shown = 0;
  for (std::size_t i = 0; i < map.values.size(); ++i)
    if (salient[i]) mass += map.values[i], mass_shown += seen[i] ? map.values[i] : 0;
  out.coverage = mass > 0 ? mass_shown / mass : 1.0;
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
    out.squash = squash_measures_of_sources(sources, significance);
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
