#include "warp/methods/polyfem/polyfem_retargeter.h"

#include <algorithm>
#include <stdexcept>

#include "warp/core/fold_blend.h"
#include "warp/core/uniform_zoom.h"
#include "warp/core/zoom_curve.h"
#include "warp/meshing/cvt_mesh.h"
#include "warp/methods/model_bytes.h"

namespace zoomwarp::warp {

namespace {

PolyfemSolution solution_of(const PolyfemModel& m) {
  PolyfemSolution s;
  s.nodes = polyfem_nodes(m.mesh);
  if (m.g_x.size() != s.nodes.positions.size() || m.g_y.size() != s.nodes.positions.size())
    throw std::invalid_argument("polyfem: the solves do not match the mesh's nodes");
  s.g_x = m.g_x;
  s.g_y = m.g_y;
  return s;
}

PolyfemSampling sampling_of(const PolyfemModel& m) {
  return sample_polyfem_cells(m.mesh, polyfem_nodes(m.mesh), PolyfemRetargeting::kExportLevel);
}

Mesh in_image_pixels(const PolyfemSampling& sampling, const PolyfemModel& m, double width, double height) {
  if (!(width > 0 && height > 0)) throw std::invalid_argument("polyfem: the image size must be positive");
  Mesh out = sampling.mesh;
  const double sx = width / m.mesh.width, sy = height / m.mesh.height;
  for (Point& p : out.vertices) p = {p.x * sx, p.y * sy};
  return out;
}

}  // namespace

PolyfemModel build_polyfem_model(const MethodInput& input) {
  const tiles::Raster& image = input.analysis_image;
  if (image.empty()) throw std::invalid_argument("polyfem precompute: no analysis image");
  const SignificanceMap& s = input.saliency;
  PolyfemModel m;
  m.mesh = build_cvt_mesh(s.values, s.width, s.height, image.width, image.height);
  const PolyfemSolution solution = solve_polyfem(m.mesh, ScalarMap{s.width, s.height, double(image.width),
                                                                    double(image.height), s.values});
  m.g_x = solution.g_x;
  m.g_y = solution.g_y;
  return m;
}

std::string polyfem_model_bytes(const PolyfemModel& m) {
  ModelBytesWriter out;
  out.put(m.mesh.width), out.put(m.mesh.height);
  out.put_count(m.mesh.vertices.size());
  for (const Point& p : m.mesh.vertices) out.put(p.x), out.put(p.y);
  out.put_count(m.mesh.cells.size());
  for (const auto& cell : m.mesh.cells) {
    out.put_count(cell.size());
    for (int v : cell) out.put(std::int32_t(v));
  }
  out.put_count(m.g_x.size());
  for (std::size_t i = 0; i < m.g_x.size(); ++i) out.put(m.g_x[i]), out.put(m.g_y[i]);
  return out.take();
}

PolyfemModel parse_polyfem_model(std::string_view bytes) {
  ModelBytesReader in(bytes, "polyfem model");
  PolyfemModel m;
  m.mesh.width = in.number(), m.mesh.height = in.number();
  if (!(m.mesh.width > 0 && m.mesh.height > 0)) in.fail("bad size");
  m.mesh.vertices.resize(in.count(16));
  for (Point& p : m.mesh.vertices) p.x = in.number(), p.y = in.number();
  m.mesh.cells.resize(in.count(4));
  for (auto& cell : m.mesh.cells) {
    cell.resize(in.count(4));
    if (cell.size() < 3) in.fail("a cell with fewer than 3 vertices");
    for (int& v : cell) v = in.index(m.mesh.vertices.size());
  }
  const std::size_t nodes = in.count(16);
  m.g_x.resize(nodes), m.g_y.resize(nodes);
  for (std::size_t i = 0; i < nodes; ++i) m.g_x[i] = in.number(), m.g_y[i] = in.number();
  in.expect_done();
  return m;
}

PolyfemRetargeting::PolyfemRetargeting(double width, double height, PolyfemModel model)
    : width_(width),
      height_(height),
      model_(std::move(model)),
      sampling_(sampling_of(model_)),
      field_(sample_polyfem_field(model_.mesh, solution_of(model_), sampling_)),
      source_(in_image_pixels(sampling_, model_, width, height)) {}

std::vector<Point> PolyfemRetargeting::warped(double tw, double th, double* blend, const StopToken* stop) const {
  // In analysis px (where g lives), scaled back per axis: the boundary lands on the rectangle.
  const double aw = model_.mesh.width, ah = model_.mesh.height;
  const double ta_w = tw * aw / width_, ta_h = th * ah / height_;
  std::vector<Point> q = warp_polyfem_samples(sampling_, field_, ta_w - aw, ta_h - ah);
  const double sx = tw / ta_w, sy = th / ta_h;
  for (Point& p : q) p = {p.x * sx, p.y * sy};
  std::vector<Point> stretch(source_.vertices.size());
  for (std::size_t i = 0; i < stretch.size(); ++i)
    stretch[i] = {source_.vertices[i].x * tw / width_, source_.vertices[i].y * th / height_};
  *blend = blend_out_folds(source_, q, stretch, stop);
  return q;
}

View PolyfemRetargeting::view(const ViewRequest& r) {
  check_view_request(r);
  check_stop(r.stop);
  // The z = 0 target of ICAZ: the screen's aspect ratio, the image's area [ICAZ §5.1].
  const ZoomGeometry g = zoom_geometry(width_, height_, r.screen_width, r.screen_height, 0, r.curve);
  WarpResult stats;
  const std::vector<Point> q = warped(g.target_width, g.target_height, &stats.affine_blend, r.stop);
  stats.converged = true;
  const Point centre{std::clamp(r.cx, 0.0, width_), std::clamp(r.cy, 0.0, height_)};
  View v = uniform_zoom(source_, q, g.target_width, g.target_height, r, locate(source_, q, centre));
  v.coarse_stats = std::move(stats);
  return v;
}

std::size_t PolyfemRetargeting::memory_bytes() {
  return 2 * source_.vertices.capacity() * sizeof(Point) + 2 * source_.triangles.capacity() * sizeof(Triangle) +
         sampling_.samples.capacity() * sizeof(PolyfemSample) +
         (field_.g_x.capacity() + field_.g_y.capacity() + model_.g_x.capacity() + model_.g_y.capacity()) * sizeof(double);
}

const RetargetingMethod& polyfem_method() {
  static const RetargetingMethod kMethod{
      .name = "polyfem",
      .summary = "polygonal finite elements [PolyFEM]: ~200 saliency-adaptive convex cells with quadratic serendipity "
                 "elements, E_T = ∫ s|J − I|² solved once per axis so that any aspect is one combination, then "
                 "zoomed uniformly",
      .zoom = "0 shows the whole retargeted image, 1 shows it 1:1 (the plain crop when the screen has the image's "
              "aspect ratio); the view centre is tracked through the warp",
      .has_mesh = true,
      .magic = {'Z', 'W', 'P', 'F', 'E', 'M', '1', 0},
      .reads_lines = false,
      .precompute = [](const MethodInput& input) { return polyfem_model_bytes(build_polyfem_model(input)); },
      .load = [](const ImageModel& model, const SignificanceMap&, std::string_view bytes) -> std::unique_ptr<Retargeter> {
        return std::make_unique<PolyfemRetargeting>(model.width, model.height, parse_polyfem_model(bytes));
      },
  };
  return kMethod;
}

}  // namespace zoomwarp::warp
