#include "warp/methods/patch/patch_retargeter.h"

#include <algorithm>
#include <stdexcept>

#include "warp/core/fold_blend.h"
#include "warp/core/uniform_zoom.h"
#include "warp/core/zoom_curve.h"

namespace zoomwarp::warp {

namespace {

Mesh in_image_pixels(const PatchModel& model, double width, double height) {
  if (!(width > 0 && height > 0)) throw std::invalid_argument("patch: the image size must be positive");
  Mesh m = patch_mesh(model.grid);
  if (model.per_width.size() != m.vertices.size() || model.per_height.size() != m.vertices.size())
    throw std::invalid_argument("patch: the model's solves do not match its grid");
  const double sx = width / model.grid.width, sy = height / model.grid.height;
  for (Point& p : m.vertices) p = {p.x * sx, p.y * sy};
  return m;
}

}  // namespace

PatchRetargeting::PatchRetargeting(double width, double height, PatchModel model)
    : width_(width), height_(height), model_(std::move(model)), mesh_(in_image_pixels(model_, width, height)) {}

std::vector<Point> PatchRetargeting::warped(double tw, double th, double* blend, const StopToken* stop) const {
  // Solved in analysis px (the bases' unit), scaled back per axis: the boundary lands exactly on
  // the target rectangle.
  const double ta_w = tw * model_.grid.width / width_, ta_h = th * model_.grid.height / height_;
  std::vector<Point> q = patch_positions(model_, ta_w, ta_h);
  const double sx = tw / ta_w, sy = th / ta_h;
  for (Point& p : q) p = {p.x * sx, p.y * sy};
  std::vector<Point> stretch(mesh_.vertices.size());
  for (std::size_t i = 0; i < stretch.size(); ++i)
    stretch[i] = {mesh_.vertices[i].x * tw / width_, mesh_.vertices[i].y * th / height_};
  *blend = blend_out_folds(mesh_, q, stretch, stop);
  return q;
}

View PatchRetargeting::view(const ViewRequest& r) {
  check_view_request(r);
  check_stop(r.stop);
  // The z = 0 target of ICAZ: the screen's aspect ratio, the image's area [ICAZ §5.1].
  const ZoomGeometry g = zoom_geometry(width_, height_, r.screen_width, r.screen_height, 0, r.curve, r.frame);
  WarpResult stats;
  const std::vector<Point> q = warped(g.target_width, g.target_height, &stats.affine_blend, r.stop);
  stats.converged = true;
  View v = uniform_zoom_of_warp(mesh_, q, g.target_width, g.target_height, r, width_, height_);
  v.coarse_stats = std::move(stats);
  return v;
}

std::size_t PatchRetargeting::memory_bytes() {
  return 2 * mesh_.vertices.capacity() * sizeof(Point) + mesh_.triangles.capacity() * sizeof(Triangle) +
         (model_.per_width.capacity() + model_.per_height.capacity()) * sizeof(Point) +
         model_.grid.quad_patch.capacity() * sizeof(int) + model_.grid.significance.capacity() * sizeof(double);
}

const RetargetingMethod& patch_method() {
  static const RetargetingMethod kMethod{
      .name = "patch",
      .summary = "patch-based warping [Lin13]: colour-homogeneous patches on a 20-px quad grid, significant patches "
                 "kept similar, the rest scaled linearly, grid lines axis-aligned; any screen aspect is one "
                 "combination of two precomputed solves, then zoomed uniformly",
      .zoom = kZoomIntoTheRetargetedImage,
      .has_mesh = true,
      .lines = "each line sampled where it crosses a triangle edge, each sample held on the chord of the "
               "line's warped ends (a linear term of ours, weight 100)",
      .magic = {'Z', 'W', 'P', 'A', 'T', 'C', 'H', '3'},
      .reads_lines = true,
      .precompute = [](const MethodInput& input) { return patch_model_bytes(build_patch_model(input)); },
      .precompute_bytes_per_pixel = 52,  // the sorted grid edges and the union-find: 39-51 MB at 996×934
      .load = [](const ImageModel& model, const SignificanceMap&, std::string_view bytes) -> std::unique_ptr<Retargeter> {
        return std::make_unique<PatchRetargeting>(model.width, model.height, parse_patch_model(bytes));
      },
  };
  return kMethod;
}

}  // namespace zoomwarp::warp
