#include "warp/methods/retarget_zoom/retarget_zoom.h"

#include <algorithm>
#include <cmath>

#include "warp/core/uniform_zoom.h"
#include "warp/core/zoom_curve.h"
#include "warp/meshing/coarse_mesh.h"

namespace zoomwarp::warp {

namespace {

// [ICAZ §6.1]: the baseline's mesh is uniform and as fine as the adaptive mesh's finest level.
CoarseMesh uniform_mesh(const ImageModel& model) {
  CoarseMeshOptions options;
  options.max_triangle_area = finest_stored_leaf_area(model);
  options.vertex_budget = RetargetZoom::kMaxVertices;
  return build_coarse_mesh(model.width, model.height, model.lines, options);
}

ShapeWarp make_warp(const ImageModel& model, const SignificanceMap& saliency) {
  CoarseMesh m = uniform_mesh(model);
  std::vector<double> weights = triangle_weights(m.mesh, saliency, model.w_min);
  return ShapeWarp(std::move(m.mesh), std::move(weights), model.width, model.height, std::move(m.line_vertices));
}

}  // namespace

double finest_stored_leaf_area(const ImageModel& model) {
  const Forest& forest = model.forest;
  double largest = 0;
  for (int n = 0; n < forest.kept_nodes(); ++n)
    if (!forest.is_split(n)) largest = std::max(largest, forest.area(n));
  return largest;
}

RetargetZoom::RetargetZoom(const ImageModel& model, const SignificanceMap& saliency)
    : width_(model.width), height_(model.height), warp_(make_warp(model, saliency)) {}

std::vector<Point> RetargetZoom::warped(double tw, double th, WarpResult* stats, const StopToken* stop) {
  const auto key = std::make_pair(std::llround(tw * 1000), std::llround(th * 1000));
  std::lock_guard lock(mu_);
  if (const std::vector<Point>* cached = cache_.find(key)) return *cached;
  // 0.05 px of the retargeted image: zoom 1 shows it 1:1, so no view sees the residual larger.
  WarpOptions options;
  options.tolerance = 0.05;
  options.fixed_line_normals = true;
  options.stop = stop;
  *stats = warp_.solve(tw, th, options);
  return cache_.put(key, stats->positions);
}

View RetargetZoom::view(const ViewRequest& r) {
  check_view_request(r);
  check_stop(r.stop);
  // The z = 0 target of ICAZ: the screen's aspect ratio, the image's area [ICAZ §5.1].
  const ZoomGeometry g = zoom_geometry(width_, height_, r.screen_width, r.screen_height, 0, r.curve);
  WarpResult stats;
  const std::vector<Point> positions = warped(g.target_width, g.target_height, &stats, r.stop);
  View v = uniform_zoom_of_warp(mesh(), positions, g.target_width, g.target_height, r, width_, height_);
  stats.positions.clear();  // `warped` has them
  v.coarse_stats = std::move(stats);
  return v;
}

std::size_t RetargetZoom::memory_bytes() {
  const Mesh& m = mesh();
  // The factor is not exposed; a Cholesky factor of this planar Laplacian under AMD holds about
  // 30 nonzeros per vertex and axis (index + value).
  const std::size_t factor = m.vertices.size() * 2 * 30 * (sizeof(double) + sizeof(int));
  return m.vertices.capacity() * sizeof(Point) + m.triangles.capacity() * sizeof(Triangle) + factor + cache_.bytes();
}

const RetargetingMethod& retarget_zoom_method() {
  static const RetargetingMethod kMethod{
      .name = "retarget-zoom",
      .summary = "the whole image warped once to the screen's aspect ratio on a uniform fine mesh (ICAZ's shape "
                 "energy), then zoomed uniformly",
      .zoom = kZoomIntoTheRetargetedImage,
      .has_mesh = true,
      .magic = {},
      .precompute = {},
      .load = [](const ImageModel& model, const SignificanceMap& saliency, std::string_view) -> std::unique_ptr<Retargeter> {
        return std::make_unique<RetargetZoom>(model, saliency);
      },
  };
  return kMethod;
}

}  // namespace zoomwarp::warp
