#include "tests/support/mesh_bend.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

namespace zoomwarp::testing {

namespace {

using nlohmann::json;

struct Vertex {
  double u, v, x, y;
};

// The mesh's triangles bucketed by their source bounding boxes on a grid, so that a point's
// triangle is found among a few.
class SourceIndex {
 public:
  explicit SourceIndex(const json& mesh) {
    for (const json& v : mesh["vertices"]) vertices_.push_back({v[0], v[1], v[2], v[3]});
    for (const json& t : mesh["triangles"]) triangles_.push_back({t[0], t[1], t[2]});
    for (const Vertex& v : vertices_) {
      max_u_ = std::max(max_u_, v.u);
      max_v_ = std::max(max_v_, v.v);
    }
    cell_ = std::max(1.0, std::max(max_u_, max_v_) / 128);
    cols_ = int(max_u_ / cell_) + 1, rows_ = int(max_v_ / cell_) + 1;
    cells_.resize(std::size_t(cols_) * rows_);
    for (std::size_t i = 0; i < triangles_.size(); ++i) {
      double u0 = 1e300, v0 = 1e300, u1 = -1e300, v1 = -1e300;
      for (int k : triangles_[i]) {
        u0 = std::min(u0, vertices_[k].u), u1 = std::max(u1, vertices_[k].u);
        v0 = std::min(v0, vertices_[k].v), v1 = std::max(v1, vertices_[k].v);
      }
      for (int r = row(v0); r <= row(v1); ++r)
        for (int c = col(u0); c <= col(u1); ++c) cells_[std::size_t(r) * cols_ + c].push_back(int(i));
    }
  }

  // The screen position of source point (u, v), or none outside the listed triangles.
  std::optional<std::array<double, 2>> map(double u, double v) const {
    if (u < 0 || v < 0 || u > max_u_ || v > max_v_) return std::nullopt;
    for (int i : cells_[std::size_t(row(v)) * cols_ + col(u)]) {
      const Vertex &a = vertices_[triangles_[i][0]], &b = vertices_[triangles_[i][1]], &c = vertices_[triangles_[i][2]];
      const double det = (b.u - a.u) * (c.v - a.v) - (c.u - a.u) * (b.v - a.v);
      if (std::abs(det) < 1e-12) continue;
      const double s = ((u - a.u) * (c.v - a.v) - (c.u - a.u) * (v - a.v)) / det;
      const double t = ((b.u - a.u) * (v - a.v) - (u - a.u) * (b.v - a.v)) / det;
      constexpr double kEps = 1e-9;
      if (s < -kEps || t < -kEps || s + t > 1 + kEps) continue;
      return std::array<double, 2>{a.x + s * (b.x - a.x) + t * (c.x - a.x), a.y + s * (b.y - a.y) + t * (c.y - a.y)};
    }
    return std::nullopt;
  }

 private:
  int col(double u) const { return std::clamp(int(u / cell_), 0, cols_ - 1); }
  int row(double v) const { return std::clamp(int(v / cell_), 0, rows_ - 1); }

  std::vector<Vertex> vertices_;
  std::vector<std::array<int, 3>> triangles_;
  double max_u_ = 0, max_v_ = 0, cell_ = 1;
  int cols_ = 1, rows_ = 1;
  std::vector<std::vector<int>> cells_;
};

}  // namespace

LineBend worst_line_bend(const json& mesh, const json& lines, double min_screen_px) {
  const SourceIndex index(mesh);
  LineBend out;
  for (const char* set : {"lines", "suggested"})
    for (const json& s : lines[set]) {
      const double u0 = s[0], v0 = s[1], u1 = s[2], v1 = s[3];
      const int n = std::max(2, int(std::ceil(std::hypot(u1 - u0, v1 - v0))));
      std::vector<std::array<double, 2>> mapped;
      for (int k = 0; k <= n; ++k) {
        const double t = double(k) / n;
        const auto p = index.map(u0 + t * (u1 - u0), v0 + t * (v1 - v0));
        if (!p) break;
        mapped.push_back(*p);
      }
      if (mapped.size() != std::size_t(n) + 1) continue;
      const auto& a = mapped.front();
      const auto& b = mapped.back();
      const double len = std::hypot(b[0] - a[0], b[1] - a[1]);
      if (len < min_screen_px) continue;
      double bend = 0;
      for (const auto& p : mapped)
        bend = std::max(bend, std::abs((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])) / len);
      ++out.measured;
      out.worst_px = std::max(out.worst_px, bend);
    }
  return out;
}

}  // namespace zoomwarp::testing
