#include "warp/core/mesh.h"

#include <algorithm>

namespace zoomwarp::warp {

std::optional<Segment> clip_segment(const Segment& s, double x0, double y0, double x1, double y1) {
  double t0 = 0, t1 = 1;
  const double dx = s.b.x - s.a.x, dy = s.b.y - s.a.y;
  const double p[4] = {-dx, dx, -dy, dy}, q[4] = {s.a.x - x0, x1 - s.a.x, s.a.y - y0, y1 - s.a.y};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0) {
      if (q[i] < 0) return std::nullopt;
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0) t0 = std::max(t0, t);
    else t1 = std::min(t1, t);
  }
  if (t0 >= t1) return std::nullopt;
  return Segment{{s.a.x + t0 * dx, s.a.y + t0 * dy}, {s.a.x + t1 * dx, s.a.y + t1 * dy}};
}

std::vector<int> vertices_on_segment(const Mesh& mesh, const Segment& s) {
  const double dx = s.b.x - s.a.x, dy = s.b.y - s.a.y, len2 = dx * dx + dy * dy;
  std::vector<std::pair<double, int>> on;
  if (len2 > 0)
    for (int i = 0; i < int(mesh.vertices.size()); ++i) {
      const Point& p = mesh.vertices[i];
      const double t = ((p.x - s.a.x) * dx + (p.y - s.a.y) * dy) / len2;
      const double cross = (p.x - s.a.x) * dy - (p.y - s.a.y) * dx;
      if (t > -1e-9 && t < 1 + 1e-9 && cross * cross < 1e-12 * len2) on.emplace_back(t, i);
    }
  std::sort(on.begin(), on.end());
  std::vector<int> ids;
  for (const auto& [t, i] : on) ids.push_back(i);
  return ids;
}

}  // namespace zoomwarp::warp
