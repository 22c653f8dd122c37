#include "warp/icaz/image_model.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace zoomwarp::warp {

namespace {

struct Box {
  double x0, y0, x1, y1;
  bool meets(const Box& o) const { return x0 <= o.x1 && o.x0 <= x1 && y0 <= o.y1 && o.y0 <= y1; }
};

// Means of the kept nodes whose bounding box meets one of `boxes` (all nodes when empty). One
// pass over the forest for all boxes: a node under several regions is averaged once, not once
// per region (a PATCH of many rectangles had cost a forest pass, and the big coarse nodes'
// means, per rectangle).
void update_node_means(ImageModel& m, const std::vector<Box>& boxes = {}) {
  m.node_mean.resize(std::size_t(m.forest.kept_nodes()));
  const auto& v = m.forest.vertices();
  for (int n = 0; n < m.forest.kept_nodes(); ++n) {
    const Triangle& t = m.forest.corners(n);
    const Point &a = v[t[0]], &b = v[t[1]], &c = v[t[2]];
    const Box node{std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y}), std::max({a.x, b.x, c.x}),
                   std::max({a.y, b.y, c.y})};
    if (!boxes.empty() && std::none_of(boxes.begin(), boxes.end(), [&](const Box& r) { return r.meets(node); }))
      continue;
    m.node_mean[n] = float(mean_over_triangle(m.significance, a, b, c));
  }
}

}  // namespace

ImageModel make_image_model(const tiles::Raster& reduced, double width, double height,
                            const std::vector<Segment>& lines, const CoarseMeshOptions& mesh,
                            const ForestOptions& forest, const SignificanceOptions& significance) {
  ImageModel m;
  m.width = width;
  m.height = height;
  m.significance = compute_significance(reduced, int(std::lround(width)), significance);
  set_lines(m, lines, mesh, forest);
  return m;
}

void set_lines(ImageModel& m, const std::vector<Segment>& lines, const CoarseMeshOptions& mesh,
               const ForestOptions& forest) {
  m.lines = m.straight_lines = lines;
  m.coarse = build_coarse_mesh(m.width, m.height, lines, mesh);
  m.forest = Forest(m.coarse.mesh);
  m.forest.build_levels(forest.min_area, forest.max_nodes);
  m.node_mean.clear();
  update_node_means(m);
}

void set_significance(ImageModel& m, SignificanceMap map) {
  m.significance = std::move(map);
  update_node_means(m);
}

void add_significance_edits(ImageModel& m, const std::vector<SignificanceEdit>& edits) {
  if (edits.empty()) return;
  // A node's mean reads the map pixels its triangle covers, or the one at its centroid: a margin
  // of two map pixels catches both.
  const double pad = 2 / m.significance.scale;
  std::vector<Box> boxes;
  for (const SignificanceEdit& edit : edits) {
    paint_polygon(m.significance, edit.polygon, edit.weight);
    m.edits.push_back(edit);
    Box b{1e300, 1e300, -1e300, -1e300};
    for (const Point& p : edit.polygon)
      b = {std::min(b.x0, p.x), std::min(b.y0, p.y), std::max(b.x1, p.x), std::max(b.y1, p.y)};
    boxes.push_back({b.x0 - pad, b.y0 - pad, b.x1 + pad, b.y1 + pad});
  }
  update_node_means(m, boxes);
}

}  // namespace zoomwarp::warp
