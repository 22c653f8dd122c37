#include "warp/image_model.h"

#include <algorithm>
#include <cmath>

namespace zoomwarp::warp {

namespace {

// Means of the kept nodes whose bounding box meets [x0, x1] × [y0, y1] (all when unbounded).
void update_node_means(ImageModel& m, double x0 = -1e300, double y0 = -1e300, double x1 = 1e300, double y1 = 1e300) {
  m.node_mean.resize(std::size_t(m.forest.kept_nodes()));
  const auto& v = m.forest.vertices();
  for (int n = 0; n < m.forest.kept_nodes(); ++n) {
    const Triangle& t = m.forest.corners(n);
    const Point &a = v[t[0]], &b = v[t[1]], &c = v[t[2]];
    if (std::max({a.x, b.x, c.x}) < x0 || std::min({a.x, b.x, c.x}) > x1 || std::max({a.y, b.y, c.y}) < y0 ||
        std::min({a.y, b.y, c.y}) > y1)
      continue;
    m.node_mean[n] = float(mean_over_triangle(m.significance, a, b, c));
  }
}

}  // namespace

ImageModel make_image_model(const tiles::Raster& reduced, double width, double height,
                            const std::vector<Segment>& lines, const CoarseMeshOptions& mesh,
                            const ForestOptions& forest) {
  ImageModel m;
  m.width = width;
  m.height = height;
  m.significance = compute_significance(reduced, int(std::lround(width)));
  set_lines(m, lines, mesh, forest);
  return m;
}

void set_lines(ImageModel& m, const std::vector<Segment>& lines, const CoarseMeshOptions& mesh,
               const ForestOptions& forest) {
  m.lines = lines;
  m.coarse = build_coarse_mesh(m.width, m.height, lines, mesh);
  m.forest = Forest(m.coarse.mesh);
  m.forest.build_levels(forest.min_area, forest.max_nodes);
  m.node_mean.clear();
  update_node_means(m);
}

void add_significance_edit(ImageModel& m, const SignificanceEdit& edit) {
  paint_polygon(m.significance, edit.polygon, edit.weight);
  m.edits.push_back(edit);
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const Point& p : edit.polygon)
    x0 = std::min(x0, p.x), y0 = std::min(y0, p.y), x1 = std::max(x1, p.x), y1 = std::max(y1, p.y);
  // A node's mean reads the map pixels its triangle covers, or the one at its centroid: a margin
  // of two map pixels catches both.
  const double pad = 2 / m.significance.scale;
  update_node_means(m, x0 - pad, y0 - pad, x1 + pad, y1 + pad);
}

}  // namespace zoomwarp::warp
