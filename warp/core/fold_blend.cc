#include "warp/core/fold_blend.h"

namespace zoomwarp::warp {

std::vector<int> folded_triangles(const Mesh& mesh, const std::vector<Point>& p) {
  std::vector<int> out;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    if (signed_area2(p[t[0]], p[t[1]], p[t[2]]) <= 0) out.push_back(int(f));
  }
  return out;
}

double blend_out_folds(const Mesh& mesh, std::vector<Point>& positions, const std::vector<Point>& fold_free,
                       const StopToken* stop) {
  if (folded_triangles(mesh, positions).empty()) return 0;
  const auto blend = [&](double t) {
    std::vector<Point> p(positions.size());
    for (std::size_t i = 0; i < p.size(); ++i)
      p[i] = {(1 - t) * positions[i].x + t * fold_free[i].x, (1 - t) * positions[i].y + t * fold_free[i].y};
    return p;
  };
  double lo = 0, hi = 1;
  for (int step = 0; step < 20; ++step) {
    check_stop(stop);
    const double mid = (lo + hi) / 2;
    (folded_triangles(mesh, blend(mid)).empty() ? hi : lo) = mid;
  }
  positions = blend(hi);
  return hi;
}

}  // namespace zoomwarp::warp
