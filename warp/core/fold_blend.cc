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
  // A blend counts as unfolded when every triangle keeps kMinAreaShare of its area under
  // `fold_free`: the smallest merely positive area would leave a triangle collapsed to a sliver,
  // which the thousandth of a pixel of /mesh's JSON can turn over (the 4:1 panorama with its
  // detected lines on a 9:16 screen did).
  constexpr double kMinAreaShare = 1e-3;
  const auto open = [&](const std::vector<Point>& p) {
    for (const Triangle& t : mesh.triangles)
      if (signed_area2(p[t[0]], p[t[1]], p[t[2]]) <
          kMinAreaShare * signed_area2(fold_free[t[0]], fold_free[t[1]], fold_free[t[2]]))
        return false;
    return true;
  };
  double lo = 0, hi = 1;
  for (int step = 0; step < 20; ++step) {
    check_stop(stop);
    const double mid = (lo + hi) / 2;
    (open(blend(mid)) ? hi : lo) = mid;
  }
  positions = blend(hi);
  return hi;
}

}  // namespace zoomwarp::warp
