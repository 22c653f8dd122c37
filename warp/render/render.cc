#include "warp/render/render.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "warp/render/level_patch.h"

namespace zoomwarp::warp {

int level_for(double magnification, int levels) {
  if (!(magnification > 0)) return levels - 1;
  const int k = int(std::floor(std::log2(1 / magnification) + 1e-9));
  return std::clamp(k, 0, levels - 1);
}

void LevelPatch::sample(double u, double v, std::uint8_t* out) const {
  const double x = u * scale - 0.5 - double(x0), y = v * scale - 0.5 - double(y0);
  const int xi = int(std::floor(x)), yi = int(std::floor(y));
  const double fx = x - xi, fy = y - yi;
  const int xa = std::clamp(xi, 0, pixels.width - 1), xb = std::clamp(xi + 1, 0, pixels.width - 1);
  const int ya = std::clamp(yi, 0, pixels.height - 1), yb = std::clamp(yi + 1, 0, pixels.height - 1);
  const int c = pixels.channels;
  const std::uint8_t *r0 = pixels.row(ya), *r1 = pixels.row(yb);
  for (int k = 0; k < c; ++k) {
    const double top = r0[xa * c + k] + fx * (r0[xb * c + k] - r0[xa * c + k]);
    const double bottom = r1[xa * c + k] + fx * (r1[xb * c + k] - r1[xa * c + k]);
    out[k] = std::uint8_t(std::lround(std::clamp(top + fy * (bottom - top), 0.0, 255.0)));
  }
}

std::pair<int, int> covered_pixels(double origin, double size, double scale, int screen_size) {
  const double lo = (0 - origin) * scale - 0.5 - 1e-9, hi = (size - origin) * scale - 0.5 + 1e-9;
  return {std::max(0, int(std::ceil(lo))), std::min(screen_size - 1, int(std::floor(hi)))};
}

bool patch_fits(const tiles::Manifest& m, int level, double source_width, double source_height, int sw, int sh) {
  constexpr double kMaxPatchSide = 16384;
  const double max_pixels = 4.0 * sw * sh + (1 << 20);
  const double scale = double(m.level_width(level)) / m.width;
  const double side_x = source_width * scale + 3, side_y = source_height * scale + 3;
  return side_x <= kMaxPatchSide && side_y <= kMaxPatchSide && side_x * side_y <= max_pixels;
}

LevelPatch read_patch(const tiles::ImageEntry& image, tiles::PyramidReader& reader, int level, double u0, double v0,
                      double u1, double v1) {
  const tiles::Manifest& m = image.manifest;
  LevelPatch p;
  p.scale = double(m.level_width(level)) / m.width;
  const long long lw = m.level_width(level), lh = m.level_height(level);
  p.x0 = std::clamp<long long>((long long)std::floor(u0 * p.scale) - 1, 0, lw - 1);
  p.y0 = std::clamp<long long>((long long)std::floor(v0 * p.scale) - 1, 0, lh - 1);
  const long long x1 = std::clamp<long long>((long long)std::ceil(u1 * p.scale) + 1, p.x0 + 1, lw);
  const long long y1 = std::clamp<long long>((long long)std::ceil(v1 * p.scale) + 1, p.y0 + 1, lh);
  p.pixels = reader.read_level(image, level, {p.x0, p.y0, x1 - p.x0, y1 - p.y0});
  return p;
}

void draw_uniform(const LevelPatch& patch, double view_x, double view_y, double scale, const tiles::Rect& pixels,
                  tiles::Raster& screen) {
  // Screen pixel (x0 + i, y0 + j) → patch position ((x0 + i + 0.5)/s + view_x)·patch.scale − 0.5 − patch.x0.
  const double k = patch.scale / scale;
  const double x0 = double(pixels.x), y0 = double(pixels.y);
  const cv::Matx23d to_patch(k, 0, ((x0 + 0.5) / scale + view_x) * patch.scale - 0.5 - double(patch.x0),  //
                             0, k, ((y0 + 0.5) / scale + view_y) * patch.scale - 0.5 - double(patch.y0));
  const tiles::Raster& px = patch.pixels;
  const cv::Mat level_pixels(px.height, px.width, CV_8UC(px.channels), const_cast<std::uint8_t*>(px.pixels.data()),
                             px.row_bytes());
  cv::Mat all(screen.height, screen.width, CV_8UC(screen.channels), screen.pixels.data(), screen.row_bytes());
  cv::Mat target = all(cv::Rect(int(pixels.x), int(pixels.y), int(pixels.w), int(pixels.h)));
  cv::warpAffine(level_pixels, target, to_patch, target.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                 cv::BORDER_REPLICATE);
}

namespace {

// std::floor / std::ceil of a value in int range, as int. Without SSE4.1's roundsd (the default
// x86-64 target) std::floor is a longer emulated sequence, and a view of 48 000 triangles takes
// ~20 of them per triangle; truncation and one compare give the same integers.
int floor_int(double x) {
  const int i = int(x);
  return i - (x < i);
}
int ceil_int(double x) {
  const int i = int(x);
  return i + (x > i);
}

// level_for(sqrt(screen_area / source_area)) per triangle without a log2 for most of them:
// level_for is non-increasing in its argument (sqrt and log2 are monotone), so a ratio between
// two ratios already seen to give level k gives k too. Per level, the smallest and largest ratio
// seen; a ratio outside every such interval is computed (and widens its level's).
class LevelOfRatio {
 public:
  explicit LevelOfRatio(int levels) : levels_(levels), lo_(levels, 1e300), hi_(levels, -1e300) {}
  int operator()(double ratio) {
    if (lo_[last_] <= ratio && ratio <= hi_[last_]) return last_;
    for (int k = 0; k < levels_; ++k)
      if (lo_[k] <= ratio && ratio <= hi_[k]) return last_ = k;
    const int k = level_for(std::sqrt(ratio), levels_);
    lo_[k] = std::min(lo_[k], ratio), hi_[k] = std::max(hi_[k], ratio);
    return last_ = k;
  }

 private:
  const int levels_;
  std::vector<double> lo_, hi_;
  int last_ = 0;
};

// Triangles drawn from one pyramid level, with the source bounding box the level has to cover
// and their screen bounding box.
struct Group {
  std::vector<int> triangles;
  double u0 = 1e300, v0 = 1e300, u1 = -1e300, v1 = -1e300;  // source
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;  // screen

  void add(int f, const Point& sa, const Point& sb, const Point& sc, const Point& a, const Point& b, const Point& c) {
    triangles.push_back(f);
    u0 = std::min({u0, sa.x, sb.x, sc.x}), u1 = std::max({u1, sa.x, sb.x, sc.x});
    v0 = std::min({v0, sa.y, sb.y, sc.y}), v1 = std::max({v1, sa.y, sb.y, sc.y});
    x0 = std::min({x0, a.x, b.x, c.x}), x1 = std::max({x1, a.x, b.x, c.x});
    y0 = std::min({y0, a.y, b.y, c.y}), y1 = std::max({y1, a.y, b.y, c.y});
  }
  void merge(const Group& g) {
    triangles.insert(triangles.end(), g.triangles.begin(), g.triangles.end());
    u0 = std::min(u0, g.u0), u1 = std::max(u1, g.u1), v0 = std::min(v0, g.v0), v1 = std::max(v1, g.v1);
    x0 = std::min(x0, g.x0), x1 = std::max(x1, g.x1), y0 = std::min(y0, g.y0), y1 = std::max(y1, g.y1);
  }
};

// `groups` is indexed by level; an empty group draws nothing. A group whose patch does not fit
// (patch_fits) is drawn from the next coarser level.
void coarsen_oversized_groups(std::vector<Group>& groups, const tiles::Manifest& m, int sw, int sh) {
  for (int level = 0; level + 1 < m.levels; ++level) {
    Group& g = groups[level];
    if (g.triangles.empty() || patch_fits(m, level, g.u1 - g.u0, g.v1 - g.v0, sw, sh)) continue;
    groups[level + 1].merge(g);  // checked in turn on the next pass of the loop
    g = Group{};
  }
}

// A uniform view (View::uniform): the image's rectangle on screen, its pixel centres resampled
// from one level by one cv::warpAffine (draw_uniform) — the same positions and level the
// triangles would give, without building a map per pixel.
void render_uniform(const View& view, int sw, int sh, const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                    tiles::Raster& screen) {
  const tiles::Manifest& m = image.manifest;
  const double s = view.geometry.screen_scale;
  if (!(s > 0)) return;
  const auto [x0, x1] = covered_pixels(view.view_x, m.width, s, sw);
  const auto [y0, y1] = covered_pixels(view.view_y, m.height, s, sh);
  if (x1 < x0 || y1 < y0) return;
  const int level = level_for(s, m.levels);
  const LevelPatch patch = read_patch(image, reader, level, view.view_x + x0 / s, view.view_y + y0 / s,
                                      view.view_x + (x1 + 1) / s, view.view_y + (y1 + 1) / s);
  draw_uniform(patch, view.view_x, view.view_y, s, {x0, y0, x1 - x0 + 1, y1 - y0 + 1}, screen);
}

// Triangles by the pyramid level that fits each one's on-screen scale, with the source box each
// level has to cover; indexed by level.
std::vector<Group> group_by_level(const Mesh& src, const std::vector<Point>& scr, const std::vector<int>& visible,
                                  int levels) {
  std::vector<Group> groups(levels);
  LevelOfRatio level_of(levels);
  for (int f : visible) {
    const Triangle& t = src.triangles[f];
    const Point &sa = src.vertices[t[0]], &sb = src.vertices[t[1]], &sc = src.vertices[t[2]];
    const Point &a = scr[t[0]], &b = scr[t[1]], &c = scr[t[2]];
    const double source_area = std::abs(signed_area2(sa, sb, sc));
    const double screen_area = std::abs(signed_area2(a, b, c));
    if (!(source_area > 0) || !(screen_area > 0)) continue;
    groups[level_of(screen_area / source_area)].add(f, sa, sb, sc, a, b, c);
  }
  return groups;
}

// The screen pixels a group's triangles may touch (clamped to the screen; empty if none).
cv::Rect group_pixels(const Group& g, int sw, int sh) {
  if (g.triangles.empty()) return {};
  const int bx0 = std::max(0, floor_int(g.x0)), bx1 = std::min(sw - 1, ceil_int(g.x1));
  const int by0 = std::max(0, floor_int(g.y0)), by1 = std::min(sh - 1, ceil_int(g.y1));
  if (bx1 < bx0 || by1 < by0) return {};
  return {bx0, by0, bx1 - bx0 + 1, by1 - by0 + 1};
}

// Where map_triangles writes a source position (u, v): (u·scale − centre − x0, v·scale − centre − y0)
// — a level patch's pixel grid ({patch.scale, 0.5, patch.x0, patch.y0}).
struct OutputGrid {
  double scale = 1, centre = 0, x0 = 0, y0 = 0;
};

// A patch position in cv::remap's fixed-point form: whole pixels (x, y) and the fraction's index
// into its bilinear table, 1/INTER_TAB_SIZE px per step — computed as remap computes it from
// float maps (OpenCV imgwarp.cpp, RemapInvoker: cvRound(position · INTER_TAB_SIZE), shifted and
// masked), so the screen is bit for bit what float maps gave, without remap converting them
// block by block or the maps taking 8 bytes a pixel.
inline void to_fixed_point(float u, float v, std::int16_t* whole, std::uint16_t* fraction) {
  const int iu = cvRound(u * float(cv::INTER_TAB_SIZE)), iv = cvRound(v * float(cv::INTER_TAB_SIZE));
  whole[0] = cv::saturate_cast<std::int16_t>(iu >> cv::INTER_BITS);
  whole[1] = cv::saturate_cast<std::int16_t>(iv >> cv::INTER_BITS);
  fraction[0] = std::uint16_t((iv & (cv::INTER_TAB_SIZE - 1)) * cv::INTER_TAB_SIZE + (iu & (cv::INTER_TAB_SIZE - 1)));
}

// One row span of a triangle, pixels xs … xs + count − 1 (entries 0 … count − 1 of the outputs),
// marked covered: the patch position of pixel centre px is u = (u0 + ux·px) + u_row, v likewise
// (u_row: the row's term), in doubles, then float, then fixed point as above. Four pixels at a
// time with OpenCV's universal intrinsics — the same operations in the same order (no FMA on the
// x86-64 baseline), so bit for bit the scalar result; the scan was the largest part of a
// viewport's CPU time, and -O2 (RelWithDebInfo) does not vectorise it.
void write_span(int xs, int count, double u0, double ux, double u_row, double v0, double vx, double v_row,
                std::int16_t* whole, std::uint16_t* fraction, std::uint8_t* covered) {
  int k = 0;
#if CV_SIMD128_64F
  const cv::v_float64x2 vu0 = cv::v_setall_f64(u0), vux = cv::v_setall_f64(ux), vur = cv::v_setall_f64(u_row);
  const cv::v_float64x2 vv0 = cv::v_setall_f64(v0), vvx = cv::v_setall_f64(vx), vvr = cv::v_setall_f64(v_row);
  const cv::v_float64x2 step01(0, 1), step23(2, 3);
  const cv::v_float32x4 tab = cv::v_setall_f32(float(cv::INTER_TAB_SIZE));
  const cv::v_int32x4 mask = cv::v_setall_s32(cv::INTER_TAB_SIZE - 1);
  for (; k + 4 <= count; k += 4) {
    const cv::v_float64x2 centre = cv::v_setall_f64(xs + k + 0.5), p01 = centre + step01, p23 = centre + step23;
    const cv::v_float32x4 u = cv::v_cvt_f32((vu0 + vux * p01) + vur, (vu0 + vux * p23) + vur);
    const cv::v_float32x4 v = cv::v_cvt_f32((vv0 + vvx * p01) + vvr, (vv0 + vvx * p23) + vvr);
    const cv::v_int32x4 iu = cv::v_round(u * tab), iv = cv::v_round(v * tab);
    const cv::v_int16x8 xy = cv::v_pack(iu >> cv::INTER_BITS, iv >> cv::INTER_BITS);  // x0..x3, y0..y3
    cv::v_int16x8 interleaved, unused;
    cv::v_zip(xy, cv::v_rotate_right<4>(xy), interleaved, unused);  // x0 y0 x1 y1 …
    cv::v_store(whole + 2 * k, interleaved);
    const cv::v_int32x4 index = ((iv & mask) << cv::INTER_BITS) | (iu & mask);
    cv::v_store_low(fraction + k, cv::v_reinterpret_as_u16(cv::v_pack(index, index)));
    std::memcpy(covered + k, "\1\1\1\1", 4);  // one store, not a memset call per row
  }
#endif
  for (; k < count; ++k) {
    const double px = xs + k + 0.5;
    to_fixed_point(float((u0 + ux * px) + u_row), float((v0 + vx * px) + v_row), whole + 2 * k, fraction + k);
    covered[k] = 1;
  }
}

// map_triangles' output, cv::remap's fixed-point maps of a level patch (write_span): what
// render_mesh remaps. span(first, xs, count, u0, ux, u_row, v0, vx, v_row) writes pixels
// xs … xs + count − 1 of one triangle row — entries first … first + count − 1 of the box's
// row-major arrays — whose grid position at pixel centre px is u = (u0 + ux·px) + u_row, v
// likewise, and marks them covered.
struct FixedPointMaps {
  std::int16_t* whole;
  std::uint16_t* fraction;
  std::uint8_t* covered;
  void span(std::size_t first, int xs, int count, double u0, double ux, double u_row, double v0, double vx,
            double v_row) const {
    write_span(xs, count, u0, ux, u_row, v0, vx, v_row, whole + 2 * first, fraction + first, covered + first);
  }
};

// Per covered pixel of `box` (screen pixels), its source position on `grid`, handed to `out`
// span by span: triangle by triangle, one affine map each. Pixels no triangle covers are not
// written.
void map_triangles(const Mesh& src, const std::vector<Point>& scr, const std::vector<int>& triangles,
                   const OutputGrid& grid, const cv::Rect& box, const FixedPointMaps& out,
                   const StopToken* stop) {
  const int bx0 = box.x, by0 = box.y, bx1 = box.x + box.width - 1, by1 = box.y + box.height - 1;
  // Row y − by0 of the outputs starts at entry (y − by0)·width.
  const std::size_t step = std::size_t(box.width);
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    // The token reads the clock: once per triangle was ~0.7 ms of a 30 000-triangle view.
    if (i % 256 == 0) check_stop(stop);
    const Triangle& t = src.triangles[triangles[i]];
    const Point &a = scr[t[0]], &b = scr[t[1]], &c = scr[t[2]];
    const double area = signed_area2(a, b, c);
    const int x0 = std::max(bx0, floor_int(std::min({a.x, b.x, c.x})));
    const int x1 = std::min(bx1, ceil_int(std::max({a.x, b.x, c.x})));
    const int y0 = std::max(by0, floor_int(std::min({a.y, b.y, c.y})));
    const int y1 = std::min(by1, ceil_int(std::max({a.y, b.y, c.y})));
    // Pixel centres inside the triangle (edges included, with a hair of tolerance so shared
    // edges leave no gap); barycentric coordinates carry them back to the source, and the
    // source to the patch's pixel grid (centres at integer + 0.5). The edge functions
    // e_i = area·λ_i and the source position are affine in the pixel centre p:
    //   e0 = cross(b − p, c − p) = (b.x·c.y − b.y·c.x) + p.x·(b.y − c.y) + p.y·(c.x − b.x),
    //   e1 = cross(p − a, c − a) = p.x·(c.y − a.y) − p.y·(c.x − a.x) + (a.y·(c.x − a.x) − a.x·(c.y − a.y)),
    //   e2 = area − e0 − e1;  (u, v) = (e0·s_a + e1·s_b + e2·s_c) / area,
    // evaluated directly per pixel (no accumulated drift: at zoom 1 the positions are exact).
    const double eps = 1e-7 * std::abs(area), sign = area > 0 ? 1 : -1;
    const Point &sa = src.vertices[t[0]], &sb = src.vertices[t[1]], &sc = src.vertices[t[2]];
    const double ax0 = b.y - c.y, ay0 = c.x - b.x, a00 = b.x * c.y - b.y * c.x;
    const double ax1 = c.y - a.y, ay1 = a.x - c.x, a01 = a.y * (c.x - a.x) - a.x * (c.y - a.y);
    // Grid coordinates: u·scale − centre − x0 with u affine in p.
    const double k_grid = grid.scale / area;
    const double ux = k_grid * (ax0 * (sa.x - sc.x) + ax1 * (sb.x - sc.x)), uy = k_grid * (ay0 * (sa.x - sc.x) + ay1 * (sb.x - sc.x));
    const double u0 = k_grid * (a00 * (sa.x - sc.x) + a01 * (sb.x - sc.x) + area * sc.x) - grid.centre - grid.x0;
    const double vx = k_grid * (ax0 * (sa.y - sc.y) + ax1 * (sb.y - sc.y)), vy = k_grid * (ay0 * (sa.y - sc.y) + ay1 * (sb.y - sc.y));
    const double v0 = k_grid * (a00 * (sa.y - sc.y) + a01 * (sb.y - sc.y) + area * sc.y) - grid.centre - grid.y0;
    // Per edge i, e_i·sign = k_i·px + sign·offset_i(py) with k_i = sign·slope_i; its reciprocal
    // is taken once per triangle, not per row.
    const std::array<double, 3> k = {sign * ax0, sign * ax1, -sign * (ax0 + ax1)};
    const std::array<double, 3> inv_k = {k[0] != 0 ? 1 / k[0] : 0, k[1] != 0 ? 1 / k[1] : 0, k[2] != 0 ? 1 / k[2] : 0};
    for (int y = y0; y <= y1; ++y) {
      const double py = y + 0.5;
      const double c0 = a00 + ay0 * py, c1 = a01 + ay1 * py;
      // The row's span: pixel centres px where every edge function is ≥ −eps, solved from
      // each edge's affine form (an edge parallel to the row holds for all of it or none).
      // Within it no pixel needs testing (write_span).
      double lo = x0 + 0.5, hi = x1 + 0.5;
      bool empty = false;
      const std::array<double, 3> offset = {c0, c1, area - c0 - c1};
      // Selects, not branches: a 3-row triangle's edges give the predictor nothing to learn.
      for (int e = 0; e < 3; ++e) {
        const double bound = -eps - sign * offset[e], at = bound * inv_k[e];
        lo = k[e] > 0 ? std::max(lo, at) : lo;
        hi = k[e] < 0 ? std::min(hi, at) : hi;
        empty |= !(k[e] > 0 || k[e] < 0) && bound > 0;
      }
      if (empty || !(lo <= hi)) continue;
      const std::size_t row = std::size_t(y - by0) * step;
      const int xs = ceil_int(lo - 0.5), xe = floor_int(hi - 0.5);
      if (xe < xs) continue;  // no pixel centre between lo and hi
      const std::size_t first = row + std::size_t(xs - bx0);
      out.span(first, xs, xe - xs + 1, u0, ux, uy * py, v0, vx, vy * py);
    }
  }
}

}  // namespace

tiles::Raster render_view(const View& view, int sw, int sh, const tiles::ImageEntry& image,
                          tiles::PyramidReader& reader, const StopToken* stop) {
  if (!view.uniform) return render_mesh(view.source, view.screen, view.visible, sw, sh, image, reader, stop);
  const tiles::Manifest& m = image.manifest;
  tiles::Raster out(sw, sh, m.channels);
  check_stop(stop);
  render_uniform(view, sw, sh, image, reader, out);
  return out;
}

tiles::Raster render_mesh(const Mesh& src, const std::vector<Point>& scr, const std::vector<int>& visible, int sw,
                          int sh, const tiles::ImageEntry& image, tiles::PyramidReader& reader, const StopToken* stop) {
  const tiles::Manifest& m = image.manifest;
  tiles::Raster out(sw, sh, m.channels);
  cv::Mat screen(sh, sw, CV_8UC(m.channels), out.pixels.data(), out.row_bytes());
  std::vector<Group> groups = group_by_level(src, scr, visible, m.levels);
  coarsen_oversized_groups(groups, m, sw, sh);

  // Per level: each covered screen pixel's position in the level's patch, written by scanning
  // the triangles (one affine map each), then all of them resampled by one cv::remap — bilinear,
  // vectorised, the border replicated — and copied under the coverage mask. (Sampling pixel by
  // pixel in doubles was 3/4 of a viewport's CPU time.)
  for (int level = 0; level < m.levels; ++level) {
    const Group& g = groups[level];
    if (g.triangles.empty()) continue;
    check_stop(stop);
    const LevelPatch patch = read_patch(image, reader, level, g.u0, g.v0, g.u1, g.v1);
    const cv::Rect box = group_pixels(g, sw, sh);
    if (box.empty()) continue;
    // Zero where nothing is drawn: an uncovered pixel samples patch pixel (0, 0), the mask keeps it out.
    cv::Mat whole(box.size(), CV_16SC2, cv::Scalar::all(0)), fraction(box.size(), CV_16UC1, cv::Scalar(0));
    cv::Mat covered(box.size(), CV_8U, cv::Scalar(0));
    const OutputGrid patch_grid{patch.scale, 0.5, double(patch.x0), double(patch.y0)};
    map_triangles(src, scr, g.triangles, patch_grid, box,
                  FixedPointMaps{whole.ptr<std::int16_t>(0), fraction.ptr<std::uint16_t>(0), covered.ptr<std::uint8_t>(0)},
                  stop);
    const tiles::Raster& px = patch.pixels;
    const cv::Mat level_pixels(px.height, px.width, CV_8UC(px.channels), const_cast<std::uint8_t*>(px.pixels.data()),
                               px.row_bytes());
    cv::Mat target = screen(box);
    if (cv::countNonZero(covered) == box.area()) {  // the usual case: straight into the screen
      cv::remap(level_pixels, target, whole, fraction, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
      continue;
    }
    cv::Mat resampled;
    cv::remap(level_pixels, resampled, whole, fraction, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    resampled.copyTo(target, covered);
  }
  return out;
}

}  // namespace zoomwarp::warp
