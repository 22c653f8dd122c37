#include "warp/methods/mp/mp_retargeter.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "warp/core/uniform_zoom.h"
#include "warp/core/zoom_curve.h"
#include "warp/methods/mp/mp_precompute.h"
#include "warp/methods/mp/mp_solve.h"

namespace zoomwarp::warp {

namespace {

Mesh in_image_pixels(const MpModel& model, double width, double height) {
  if (model.mesh.vertices.empty() || model.mesh.triangles.empty())
    throw std::invalid_argument("the mp model has no mesh");
  if (!(width > 0 && height > 0 && model.width > 0 && model.height > 0))
    throw std::invalid_argument("the mp model's sizes must be positive");
  Mesh m = model.mesh;
  const double sx = width / model.width, sy = height / model.height;
  for (Point& p : m.vertices) p = {p.x * sx, p.y * sy};
  return m;
}

}  // namespace

MpRetargeting::MpRetargeting(double width, double height, MpModel model)
    : width_(width), height_(height), model_(std::move(model)), mesh_(in_image_pixels(model_, width, height)) {}

MpRetargeting::Solved MpRetargeting::warped(double tw, double th, const StopToken* stop) {
  const auto key = std::make_pair(std::llround(tw * 1000), std::llround(th * 1000));
  std::lock_guard lock(mu_);
  if (const Solved* cached = cache_.find(key)) return *cached;
  MpSolveOptions options;
  options.stop = stop;
  // The warm start: the cached solve whose aspect ratio is nearest (log-ratio distance).
  const Solved* nearest = nullptr;
  double distance = 0;
  for (const auto& [size, solved] : cache_.entries()) {
    const double d = std::abs(std::log((solved.target_width / solved.target_height) / (tw / th)));
    if (!nearest || d < distance) nearest = &solved, distance = d;
  }
  if (nearest) {
    options.warm_start = nearest->positions;
    options.warm_width = nearest->target_width;
    options.warm_height = nearest->target_height;
  }
  Solved s;
  s.target_width = tw * model_.width / width_;
  s.target_height = th * model_.height / height_;
  MpSolution sol = mp_solve(model_, s.target_width, s.target_height, options);
  s.positions = std::move(sol.positions);
  s.stats.iterations = sol.iterations;
  s.stats.converged = sol.rigid;
  s.stats.inverted = sol.folds;
  return cache_.put(key, std::move(s));
}

View MpRetargeting::view(const ViewRequest& r) {
  check_view_request(r);
  check_stop(r.stop);
  // The z = 0 target of ICAZ: the screen's aspect ratio, the image's area [ICAZ §5.1].
  const ZoomGeometry g = zoom_geometry(width_, height_, r.screen_width, r.screen_height, 0, r.curve, r.frame);
  Solved s = warped(g.target_width, g.target_height, r.stop);
  const double sx = g.target_width / s.target_width, sy = g.target_height / s.target_height;
  for (Point& p : s.positions) p = {p.x * sx, p.y * sy};
  View v = uniform_zoom_of_warp(mesh_, s.positions, g.target_width, g.target_height, r, width_, height_);
  v.coarse_stats = std::move(s.stats);
  return v;
}

std::size_t MpRetargeting::memory_bytes() {
  const auto mesh_bytes = [](const Mesh& m) {
    return m.vertices.capacity() * sizeof(Point) + m.triangles.capacity() * sizeof(Triangle);
  };
  std::size_t bytes = 2 * mesh_bytes(mesh_) +
                      (model_.row_object_length.capacity() + model_.column_object_length.capacity()) * sizeof(double);
  for (const MpObject& o : model_.objects) bytes += o.vertices.capacity() * sizeof(int);
  for (const MpLine& l : model_.lines) bytes += l.points.capacity() * sizeof(MpLinePoint);
  return bytes + cache_.bytes();
}

const RetargetingMethod& mp_method() {
  static const RetargetingMethod kMethod{
      .name = "mp",
      .summary = "mesh parametrization [Guo09]: salient objects scaled rigidly, the rest stretched toward ideal "
                 "per-row and per-column lengths, detected and curator lines kept straight, then zoomed uniformly",
      .zoom = kZoomIntoTheRetargetedImage,
      .has_mesh = true,
      .lines = "lines are held collinear over their whole length by [Guo09 eq. 7]'s structure term (cross-product "
               "form, weight 1e5), as chains of mesh edges cut back where they cross and points between them",
      .magic = {'Z', 'W', 'M', 'P', 'M', 'D', 'L', '3'},
      .reads_lines = true,
      .precompute = [](const MethodInput& input) { return mp_model_bytes(build_mp_model(input)); },
      .precompute_bytes_per_pixel = 4,  // under 2 MB at 996×934
      .load = [](const ImageModel& model, const SignificanceMap&, std::string_view bytes) -> std::unique_ptr<Retargeter> {
        return std::make_unique<MpRetargeting>(model.width, model.height, parse_mp_model(bytes));
      },
  };
  return kMethod;
}

}  // namespace zoomwarp::warp
