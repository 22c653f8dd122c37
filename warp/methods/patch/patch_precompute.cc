#include "warp/methods/patch/patch_precompute.h"

#include <stdexcept>

#include "warp/methods/method_lines.h"
#include "warp/methods/model_bytes.h"
#include "warp/methods/patch/patch_segmentation.h"

namespace zoomwarp::warp {

PatchModel build_patch_model(const MethodInput& input, const PatchPrecomputeOptions& options) {
  const tiles::Raster& image = input.analysis_image;
  if (image.empty() || input.model.width <= 0) throw std::invalid_argument("patch precompute: no analysis image");
  const Patches patches = segment_patches(image, options.segmentation);
  PatchModel m;
  m.grid = make_patch_grid(patches, input.saliency, double(image.width) / input.model.width, options.energy);
  PatchBasis basis = solve_patch_basis(m.grid, method_lines(input), options.energy);
  m.per_width = std::move(basis.per_width);
  m.per_height = std::move(basis.per_height);
  return m;
}

std::string patch_model_bytes(const PatchModel& m) {
  ModelBytesWriter out;
  out.put(m.grid.width), out.put(m.grid.height);
  out.put(std::int32_t(m.grid.nx)), out.put(std::int32_t(m.grid.ny));
  out.put_count(m.grid.significance.size());
  for (double s : m.grid.significance) out.put(s);
  for (int p : m.grid.quad_patch) out.put(std::int32_t(p));
  for (std::size_t v = 0; v < m.per_width.size(); ++v)
    out.put(m.per_width[v].x), out.put(m.per_width[v].y), out.put(m.per_height[v].x), out.put(m.per_height[v].y);
  return out.take();
}

PatchModel parse_patch_model(std::string_view bytes) {
  ModelBytesReader in(bytes, "patch model");
  PatchModel m;
  PatchGrid& g = m.grid;
  g.width = in.number(), g.height = in.number();
  g.nx = in.get<std::int32_t>(), g.ny = in.get<std::int32_t>();
  if (!(g.width > 0 && g.height > 0) || g.nx < 1 || g.ny < 1) in.fail("bad grid size");
  g.significance.resize(in.count(8));
  for (double& s : g.significance) {
    s = in.number();
    if (s < 0 || s > 1) in.fail("a significance outside [0, 1]");
  }
  const std::size_t quads = std::size_t(g.nx) * g.ny, vertices = std::size_t(g.nx + 1) * (g.ny + 1);
  // Every quad and vertex must be there: the sizes follow from nx, ny, so check before allocating.
  if (quads > bytes.size() / 4 || vertices > bytes.size() / 32) in.fail("the grid is larger than the bytes");
  g.quad_patch.resize(quads);
  for (int& p : g.quad_patch) p = in.index(g.significance.size());
  m.per_width.resize(vertices);
  m.per_height.resize(vertices);
  for (std::size_t v = 0; v < vertices; ++v)
    m.per_width[v].x = in.number(), m.per_width[v].y = in.number(), m.per_height[v].x = in.number(),
    m.per_height[v].y = in.number();
  in.expect_done();
  return m;
}

Mesh patch_mesh(const PatchGrid& g) {
  Mesh mesh;
  for (int j = 0; j <= g.ny; ++j)
    for (int i = 0; i <= g.nx; ++i) mesh.vertices.push_back(g.position(i, j));
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      mesh.triangles.push_back({g.vertex(i, j), g.vertex(i + 1, j), g.vertex(i + 1, j + 1)});
      mesh.triangles.push_back({g.vertex(i, j), g.vertex(i + 1, j + 1), g.vertex(i, j + 1)});
    }
  return mesh;
}

std::vector<Point> patch_positions(const PatchModel& m, double tw, double th) {
  std::vector<Point> q(m.per_width.size());
  for (std::size_t v = 0; v < q.size(); ++v)
    q[v] = {tw * m.per_width[v].x + th * m.per_height[v].x, tw * m.per_width[v].y + th * m.per_height[v].y};
  return q;
}

}  // namespace zoomwarp::warp
