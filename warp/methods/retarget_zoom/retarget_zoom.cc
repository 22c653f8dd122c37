#include "warp/methods/retarget_zoom/retarget_zoom.h"

#include <algorithm>
#include <cmath>

#include "warp/core/uniform_zoom.h"
#include "warp/core/zoom_curve.h"
#include "warp/meshing/coarse_mesh.h"
#include "warp/render/render.h"

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
  return ShapeWarp(std::move(m.mesh), std::move(weights), model.width, model.height, model.straight_lines);
}

}  // namespace

double finest_stored_leaf_area(const ImageModel& model) {
  const Forest& forest = model.forest;
  double largest = 0;
  for (int n = 0; n < forest.kept_nodes(); ++n)
    if (!forest.is_split(n)) largest = std::max(largest, forest.area(n));
  return largest;
}

RetargetZoom::RetargetZoom(const ImageModel& model, const SignificanceMap& saliency, std::size_t tile_cache_bytes)
    : width_(model.width), height_(model.height), warp_(make_warp(model, saliency)), tiles_(tile_cache_bytes) {}

RetargetZoom::Positions RetargetZoom::warped(double tw, double th, WarpResult* stats, const StopToken* stop) {
  const auto key = std::make_pair(std::llround(tw * 1000), std::llround(th * 1000));
  std::lock_guard lock(mu_);
  if (const Positions* cached = cache_.find(key)) return *cached;
  // 0.05 px of the retargeted image: zoom 1 shows it 1:1, so no view sees the residual larger.
  WarpOptions options;
  options.tolerance = 0.05;
  options.fixed_line_normals = true;
  options.rotation_weight = warp_.factored_once() ? 0 : kRotationWeight;
  options.stop = stop;
  *stats = warp_.solve(tw, th, options);
  Positions solved = std::make_shared<const std::vector<Point>>(std::move(stats->positions));
  stats->positions.clear();
  return cache_.put(key, std::move(solved));
}

RetargetZoom::Warped RetargetZoom::warped_view(const ViewRequest& r) {
  check_view_request(r);
  check_stop(r.stop);
  Warped out;
  // The z = 0 target of ICAZ: the screen's aspect ratio, the image's area [ICAZ §5.1].
  out.geometry = zoom_geometry(width_, height_, r.screen_width, r.screen_height, 0, r.curve, r.frame);
  out.warp = warped(out.geometry.target_width, out.geometry.target_height, &out.stats, r.stop);
  const Point centre = request_centre(r, width_, height_);
  out.centre = locate(mesh(), *out.warp, centre, locator_.find(centre));
  return out;
}

View RetargetZoom::view(const ViewRequest& r) {
  Warped w = warped_view(r);
  View v = uniform_zoom(mesh(), *w.warp, w.geometry.target_width, w.geometry.target_height, r, w.centre);
  v.coarse_stats = std::move(w.stats);
  return v;
}

tiles::Raster RetargetZoom::draw(const std::vector<Point>& warp, const ZoomPlacement& place, int w, int h,
                                 const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                                 const StopToken* stop) const {
  const std::vector<Point> screen = place.on_screen(warp);
  return render_mesh(mesh(), screen, visible_triangles(mesh(), screen, w, h), w, h, image, reader, stop);
}

RenderedTiles::Image RetargetZoom::retargeted(const Warped& w, const tiles::ImageEntry& image) {
  const double tw = w.geometry.target_width, th = w.geometry.target_height;
  return {image.manifest.version + "|" + std::to_string(std::llround(tw * 1000)) + "x" + std::to_string(std::llround(th * 1000)),
          tw, th, image.manifest.channels};
}

RenderedTiles::DrawTile RetargetZoom::tile_drawer(const Warped& w, const tiles::ImageEntry& image,
                                                  tiles::PyramidReader& reader, const StopToken* stop) const {
  return [this, warp = w.warp, &image, &reader, stop](int level, const tiles::Rect& rect) {
    const ZoomPlacement place{std::ldexp(1.0, -level), -double(rect.x), -double(rect.y)};
    return draw(*warp, place, int(rect.w), int(rect.h), image, reader, stop);
  };
}

tiles::Raster RetargetZoom::render(const ViewRequest& r, const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  const Warped w = warped_view(r);
  const ZoomPlacement place = zoom_placement(w.geometry.target_width, w.geometry.target_height, r, w.centre);
  const RenderedTiles::Image retargeted_image = retargeted(w, image);
  if (!tiles_.keeps(retargeted_image, place.scale))
    return draw(*w.warp, place, r.screen_width, r.screen_height, image, reader, r.stop);
  return tiles_.view(retargeted_image, place, r.screen_width, r.screen_height, tile_drawer(w, image, reader, r.stop),
                     r.stop);
}

std::shared_ptr<const tiles::Raster> RetargetZoom::tile(const ViewRequest& r, int level, int tx, int ty,
                                                        const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  const Warped w = warped_view(r);
  return tiles_.tile(retargeted(w, image), level, tx, ty, tile_drawer(w, image, reader, r.stop), r.stop);
}

std::size_t RetargetZoom::memory_bytes() {
  const Mesh& m = mesh();
  // The factor is not exposed; a Cholesky factor of this planar Laplacian under AMD holds about
  // 30 nonzeros per vertex and axis (index + value).
  const std::size_t factor = m.vertices.size() * 2 * 30 * (sizeof(double) + sizeof(int));
  return m.vertices.capacity() * sizeof(Point) + m.triangles.capacity() * sizeof(Triangle) + factor + locator_.memory_bytes() +
         cache_.bytes() + tiles_.bytes();
}

const RetargetingMethod& retarget_zoom_method() {
  static const RetargetingMethod kMethod{
      .name = "retarget-zoom",
      .summary = "the whole image warped once to the screen's aspect ratio on a uniform fine mesh (ICAZ's shape "
                 "energy, with a rotation term that keeps salient shapes upright), then zoomed uniformly",
      .zoom = kZoomIntoTheRetargetedImage,
      .has_mesh = true,
      .lines = "the line set's lines are edges of its uniform mesh and keep their normal from the affine "
               "stretch (ICAZ's line term, [ICAZ §4.3])",
      .magic = {},
      .loads_lines = true,
      .precompute = {},
      .load = [](const ImageModel& model, const SignificanceMap& saliency, std::string_view) -> std::unique_ptr<Retargeter> {
        return std::make_unique<RetargetZoom>(model, saliency);
      },
  };
  return kMethod;
}

}  // namespace zoomwarp::warp
