#include "warp/core/mesh.h"

#include <algorithm>

namespace zoomwarp::warp {

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
