#include "warp/render/inverse_map.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "warp/core/triangle_locator.h"
#include "warp/render/level_patch.h"
#include "warp/render/render.h"

namespace zoomwarp::warp {

namespace {

// Per node, log2(1 / stretch) from the central differences of the source positions (one-sided at
// the grid's edges): the inverse map's Jacobian J (source px per warped px), stretch = 1/sqrt|det J|.
void fill_fineness(InverseMap& map) {
  map.fineness.resize(std::size_t(map.cols) * map.rows);
  const auto at = [&](int i, int j, int c) { return double(map.uv[2 * (std::size_t(j) * map.cols + i) + c]); };
  for (int j = 0; j < map.rows; ++j)
    for (int i = 0; i < map.cols; ++i) {
      const int il = std::max(0, i - 1), ir = std::min(map.cols - 1, i + 1);
      const int jt = std::max(0, j - 1), jb = std::min(map.rows - 1, j + 1);
      const double dx = (ir - il) / map.per_x, dy = (jb - jt) / map.per_y;
      const double ux = (at(ir, j, 0) - at(il, j, 0)) / dx, vx = (at(ir, j, 1) - at(il, j, 1)) / dx;
      const double uy = (at(i, jb, 0) - at(i, jt, 0)) / dy, vy = (at(i, jb, 1) - at(i, jt, 1)) / dy;
      const double det = std::abs(ux * vy - uy * vx);
      map.fineness[std::size_t(j) * map.cols + i] = det > 0 ? float(0.5 * std::log2(det)) : 0.f;
    }
}

// Nodes no triangle covered: the affine extension of the triangle TriangleLocator finds for the
// node's warped position (the nearest one for a point just off the mesh).
void fill_uncovered(const Mesh& source, const std::vector<Point>& warped, InverseMap& map,
                    const std::vector<std::uint8_t>& covered) {
  if (std::find(covered.begin(), covered.end(), 0) == covered.end()) return;
  const Mesh warped_mesh{warped, source.triangles};
  const TriangleLocator locator(warped_mesh);
  for (int j = 0; j < map.rows; ++j)
    for (int i = 0; i < map.cols; ++i) {
      const std::size_t n = std::size_t(j) * map.cols + i;
      if (covered[n]) continue;
      const MeshPoint at = locator.find({i / map.per_x, j / map.per_y});
      Point p{i / map.per_x, j / map.per_y};  // no triangle of positive area: the identity
      if (at.triangle >= 0) {
        const Triangle& t = source.triangles[at.triangle];
        p = combine(at.barycentric, source.vertices[t[0]], source.vertices[t[1]], source.vertices[t[2]]);
      }
      map.uv[2 * n] = float(p.x), map.uv[2 * n + 1] = float(p.y);
    }
}

// The map's interpolation error at every cell's centre (see InverseMap::max_error): the cell's
// bilinear value (the mean of its four nodes) carried forward through the triangle holding the
// centre, against the centre itself.
double interpolation_error(const Mesh& source, const std::vector<Point>& warped, const InverseMap& map,
                           const StopToken* stop) {
  const Mesh warped_mesh{warped, source.triangles};
  const TriangleLocator locator(warped_mesh);
  const auto node = [&](int i, int j) {
    const std::size_t n = 2 * (std::size_t(j) * map.cols + i);
    return Point{map.uv[n], map.uv[n + 1]};
  };
  double worst = 0;
  for (int j = 0; j + 1 < map.rows; ++j) {
    if (j % 64 == 0) check_stop(stop);
    for (int i = 0; i + 1 < map.cols; ++i) {
      const Point q{(i + 0.5) / map.per_x, (j + 0.5) / map.per_y};
      const MeshPoint at = locator.find(q);
      if (at.triangle < 0) continue;
      const Point a = node(i, j), b = node(i + 1, j), c = node(i, j + 1), d = node(i + 1, j + 1);
      const Point mean{(a.x + b.x + c.x + d.x) / 4, (a.y + b.y + c.y + d.y) / 4};
      const Triangle& t = source.triangles[at.triangle];
      const auto& src = source.vertices;
      const Point forward = combine(barycentric(mean, src[t[0]], src[t[1]], src[t[2]]), warped[t[0]], warped[t[1]], warped[t[2]]);
      worst = std::max(worst, std::hypot(forward.x - q.x, forward.y - q.y));
    }
  }
  return worst;
}

}  // namespace

InverseMap inverse_map_grid(double tw, double th, std::size_t max_nodes) {
  InverseMap map;
  const double per = std::min(1.0, std::sqrt(double(max_nodes) / std::max(1.0, tw * th)));
  map.cols = std::max(2, int(std::floor(tw * per)) + 1);
  map.rows = std::max(2, int(std::floor(th * per)) + 1);
  map.per_x = (map.cols - 1) / tw, map.per_y = (map.rows - 1) / th;
  return map;
}

InverseMap build_inverse_map(const Mesh& source, const std::vector<Point>& warped, double tw, double th,
                             std::size_t max_nodes, const StopToken* stop) {
  InverseMap map = inverse_map_grid(tw, th, max_nodes);
  // Node (i, j) is the grid pixel whose centre is (i + 0.5, j + 0.5).
  std::vector<Point> grid;
  grid.reserve(warped.size());
  for (const Point& q : warped) grid.push_back({q.x * map.per_x + 0.5, q.y * map.per_y + 0.5});
  const std::size_t nodes = std::size_t(map.cols) * map.rows;
  std::vector<float> u(nodes), v(nodes);
  std::vector<std::uint8_t> covered(nodes, 0);
  rasterise_inverse(source, grid, map.cols, map.rows, u.data(), v.data(), covered.data(), stop);
  map.uv.resize(2 * nodes);
  for (std::size_t n = 0; n < nodes; ++n) map.uv[2 * n] = u[n], map.uv[2 * n + 1] = v[n];
  fill_uncovered(source, warped, map, covered);
  fill_fineness(map);
  map.max_error = interpolation_error(source, warped, map, stop);
  return map;
}

bool grid_serves(const InverseMap& grid, double scale) { return scale <= std::min(grid.per_x, grid.per_y); }

bool map_serves(const InverseMap& map, double scale) {
  return grid_serves(map, scale) && scale * map.max_error <= kMaxMapError;
}

ScreenPositions screen_positions(const InverseMap& map, const ZoomPlacement& place, int sw, int sh) {
  ScreenPositions out;
  const double s = place.scale;
  if (!(s > 0) || map.uv.empty()) return out;
  const double tw = (map.cols - 1) / map.per_x, th = (map.rows - 1) / map.per_y;
  const auto [x0, x1] = covered_pixels(-place.ox / s, tw, s, sw);
  const auto [y0, y1] = covered_pixels(-place.oy / s, th, s, sh);
  if (x1 < x0 || y1 < y0) return out;
  out.x0 = x0, out.y0 = y0, out.width = x1 - x0 + 1, out.height = y1 - y0 + 1;
  out.uv.resize(2 * std::size_t(out.width) * out.height);
  // Screen pixel (x0 + i, y0 + j) → warped ((x0 + i + 0.5 − ox)/s, …) → node (· per_x, · per_y).
  const double kx = map.per_x / s, ky = map.per_y / s;
  const cv::Matx23d to_node(kx, 0, (x0 + 0.5 - place.ox) * kx, 0, ky, (y0 + 0.5 - place.oy) * ky);
  const cv::Mat nodes(map.rows, map.cols, CV_32FC2, const_cast<float*>(map.uv.data()));
  cv::Mat positions(out.height, out.width, CV_32FC2, out.uv.data());
  cv::warpAffine(nodes, positions, to_node, positions.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                 cv::BORDER_REPLICATE);
  return out;
}

namespace {

// Each drawn pixel's pyramid level: level_for(scale·stretch) = ⌊log2(1/scale) + fineness⌋ clamped,
// the fineness resampled at the pixel centres as the positions are.
std::vector<std::uint8_t> pixel_levels(const InverseMap& map, const ZoomPlacement& place, const ScreenPositions& at,
                                       int levels) {
  const double kx = map.per_x / place.scale, ky = map.per_y / place.scale;
  const cv::Matx23d to_node(kx, 0, (at.x0 + 0.5 - place.ox) * kx, 0, ky, (at.y0 + 0.5 - place.oy) * ky);
  const cv::Mat nodes(map.rows, map.cols, CV_32F, const_cast<float*>(map.fineness.data()));
  cv::Mat fineness;
  cv::warpAffine(nodes, fineness, to_node, cv::Size(at.width, at.height), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                 cv::BORDER_REPLICATE);
  std::vector<std::uint8_t> out(std::size_t(at.width) * at.height);
  const float base = float(std::log2(1 / place.scale) + 1e-9);
  const float* f = fineness.ptr<float>(0);
  for (std::size_t n = 0; n < out.size(); ++n) {
    // ⌊x⌋ by truncation and a compare (std::floor is emulated without SSE4.1, see render.cc).
    const float x = base + f[n];
    const int k = int(x) - (x < float(int(x)));
    out[n] = std::uint8_t(std::clamp(k, 0, levels - 1));
  }
  return out;
}

// Per level, the source box of the pixels drawn from it and how many they are (one pass).
struct LevelUse {
  float u0 = 1e30f, v0 = 1e30f, u1 = -1e30f, v1 = -1e30f;
  std::size_t pixels = 0;
  void merge(const LevelUse& o) {
    u0 = std::min(u0, o.u0), v0 = std::min(v0, o.v0), u1 = std::max(u1, o.u1), v1 = std::max(v1, o.v1);
    pixels += o.pixels;
  }
};
std::vector<LevelUse> level_uses(const ScreenPositions& at, const std::vector<std::uint8_t>& level_of, int levels) {
  std::vector<LevelUse> uses(levels);
  // Runs of one level are long (a level changes where the warp's stretch crosses a power of 2):
  // each run is gathered in registers and merged once.
  for (std::size_t n = 0; n < level_of.size();) {
    const std::uint8_t level = level_of[n];
    LevelUse run;
    const std::size_t start = n;
    for (; n < level_of.size() && level_of[n] == level; ++n) {
      const float u = at.uv[2 * n], v = at.uv[2 * n + 1];
      run.u0 = std::min(run.u0, u), run.u1 = std::max(run.u1, u), run.v0 = std::min(run.v0, v), run.v1 = std::max(run.v1, v);
    }
    run.pixels = n - start;
    uses[level].merge(run);
  }
  return uses;
}

// The pixels of `level` remapped from its patch into `target` (the drawn rectangle); `all`: every
// pixel is of this level (no mask).
void draw_level(const ScreenPositions& at, const std::vector<std::uint8_t>& level_of, int level, bool all,
                const LevelPatch& patch, cv::Mat& target) {
  // Source positions → the patch's pixel grid (centres at integer + 0.5), as render_mesh maps them;
  // other levels' pixels sample anything valid and the mask keeps them out.
  // In floats: a patch is at most 16 384 px wide, so their 24 bits keep 1/1000 px.
  const float k = float(patch.scale), dx = float(-0.5 - double(patch.x0)), dy = float(-0.5 - double(patch.y0));
  cv::Mat positions(at.height, at.width, CV_32FC2);
  float* p = positions.ptr<float>(0);
  for (std::size_t n = 0; n < level_of.size(); ++n) {
    const bool mine = level_of[n] == level;
    p[2 * n] = mine ? at.uv[2 * n] * k + dx : 0.f;
    p[2 * n + 1] = mine ? at.uv[2 * n + 1] * k + dy : 0.f;
  }
  const tiles::Raster& px = patch.pixels;
  const cv::Mat level_pixels(px.height, px.width, CV_8UC(px.channels), const_cast<std::uint8_t*>(px.pixels.data()),
                             px.row_bytes());
  if (all) {
    cv::remap(level_pixels, target, positions, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    return;
  }
  const cv::Mat mask = cv::Mat(at.height, at.width, CV_8U, const_cast<std::uint8_t*>(level_of.data())) == level;
  cv::Mat resampled;
  cv::remap(level_pixels, resampled, positions, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  resampled.copyTo(target, mask);
}

}  // namespace

tiles::Raster render_through_map(const InverseMap& map, const ZoomPlacement& place, int sw, int sh,
                                 const tiles::ImageEntry& image, tiles::PyramidReader& reader, const StopToken* stop) {
  const tiles::Manifest& m = image.manifest;
  tiles::Raster out(sw, sh, m.channels);
  check_stop(stop);
  const ScreenPositions at = screen_positions(map, place, sw, sh);
  if (at.uv.empty()) return out;
  std::vector<std::uint8_t> level_of = pixel_levels(map, place, at, m.levels);
  std::vector<LevelUse> uses = level_uses(at, level_of, m.levels);
  // A level whose patch does not fit hands its pixels to the next coarser one (checked in turn).
  for (int level = 0; level + 1 < m.levels; ++level) {
    LevelUse& use = uses[level];
    if (use.pixels == 0 || patch_fits(m, level, use.u1 - use.u0, use.v1 - use.v0, sw, sh)) continue;
    for (std::uint8_t& l : level_of) l = l == level ? std::uint8_t(level + 1) : l;
    uses[level + 1].merge(use);
    use = LevelUse{};
  }
  cv::Mat screen(sh, sw, CV_8UC(m.channels), out.pixels.data(), out.row_bytes());
  cv::Mat target = screen(cv::Rect(at.x0, at.y0, at.width, at.height));
  for (int level = 0; level < m.levels; ++level) {
    const LevelUse& use = uses[level];
    if (use.pixels == 0) continue;
    check_stop(stop);
    const LevelPatch patch = read_patch(image, reader, level, use.u0, use.v0, use.u1, use.v1);
    draw_level(at, level_of, level, use.pixels == level_of.size(), patch, target);
  }
  return out;
}

}  // namespace zoomwarp::warp
