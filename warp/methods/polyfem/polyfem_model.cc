#include "warp/methods/polyfem/polyfem_model.h"

#include <algorithm>
#include <stdexcept>

#include "warp/core/parallel_for.h"
#include "warp/meshing/cvt_mesh.h"
#include "warp/methods/method_lines.h"
#include "warp/methods/model_bytes.h"
#include "warp/methods/polyfem/polyfem_export.h"

namespace zoomwarp::warp {

namespace {

// The saliency-adaptive mesh [PolyFEM §4.3.2]; where its E_se descent [eq. 10] cannot remove the
// short edges (a density with edges everywhere, e.g. a fine checkerboard: ρ = 1/d³ changes at
// every pixel), the unweighted CVT (ρ = 1), whose cells are well shaped — ours: the paper has no
// answer, and one method must not refuse an image the others take. The saliency still weighs
// the energy through s.
PolygonMesh polyfem_mesh(const SignificanceMap& s, double width, double height) {
  try {
    return build_cvt_mesh(s.values, s.width, s.height, width, height);
  } catch (const std::runtime_error&) {
    return build_cvt_mesh(std::vector<float>(s.values.size(), 0.0f), s.width, s.height, width, height);
  }
}

}  // namespace

PolyfemModel build_polyfem_model(const MethodInput& input, const PolyfemOptions& options) {
  const tiles::Raster& image = input.analysis_image;
  if (image.empty()) throw std::invalid_argument("polyfem precompute: no analysis image");
  const SignificanceMap& s = input.saliency;
  PolyfemModel m;
  m.mesh = polyfem_mesh(s, image.width, image.height);
  m.solution = solve_polyfem(m.mesh, ScalarMap{s.width, s.height, double(image.width), double(image.height), s.values},
                             options, method_lines(input));
  m.fold_free = polyfem_fold_free_range(m.mesh, m.solution, options);
  const std::vector<Point> g = polyfem_g_field(m.solution);
  m.chord.resize(m.mesh.cells.size());
  parallel_for(int(m.mesh.cells.size()), [&](int c) {
    const std::vector<Point> levels = polyfem_chord_deviations(m.mesh, m.solution.nodes, c, PolyfemModel::kChordLevels, g);
    std::copy(levels.begin(), levels.end(), m.chord[c].begin());
  });
  return m;
}

std::string polyfem_model_bytes(const PolyfemModel& m) {
  ModelBytesWriter out;
  out.put(m.mesh.width), out.put(m.mesh.height);
  out.put_count(m.mesh.vertices.size());
  for (const Point& p : m.mesh.vertices) out.put(p.x), out.put(p.y);
  out.put_count(m.mesh.cells.size());
  for (std::size_t c = 0; c < m.mesh.cells.size(); ++c) {
    out.put_count(m.mesh.cells[c].size());
    for (int v : m.mesh.cells[c]) out.put(std::int32_t(v));
    for (const Point& delta : m.chord[c]) out.put(delta.x), out.put(delta.y);
  }
  const PolyfemSolution& s = m.solution;
  out.put_count(s.g_x.size());
  for (std::size_t i = 0; i < s.g_x.size(); ++i) out.put(s.g_x[i]), out.put(s.g_y[i]);
  for (const SymmetricMatrix* k : {&s.stiffness, &s.line_x, &s.line_y}) {
    out.put_count(k->value.size());
    for (std::size_t e = 0; e < k->value.size(); ++e)
      out.put(std::int32_t(k->row[e])), out.put(std::int32_t(k->col[e])), out.put(k->value[e]);
  }
  out.put(m.fold_free.low), out.put(m.fold_free.high);
  return out.take();
}

PolyfemModel parse_polyfem_model(std::string_view bytes) {
  ModelBytesReader in(bytes, "polyfem model");
  PolyfemModel m;
  m.mesh.width = in.number(), m.mesh.height = in.number();
  if (!(m.mesh.width > 0 && m.mesh.height > 0)) in.fail("bad size");
  m.mesh.vertices.resize(in.count(16));
  for (Point& p : m.mesh.vertices) p.x = in.number(), p.y = in.number();
  m.mesh.cells.resize(in.count(4 * 3 + 16 * PolyfemModel::kChordLevels));
  for (auto& cell : m.mesh.cells) {
    cell.resize(in.count(4));
    if (cell.size() < 3) in.fail("a cell with fewer than 3 vertices");
    for (int& v : cell) v = in.index(m.mesh.vertices.size());
    std::array<Point, PolyfemModel::kChordLevels> delta;
    for (Point& d : delta) d = {in.number(), in.number()};
    m.chord.push_back(delta);
  }
  try {
    m.solution.nodes = polyfem_nodes(m.mesh);
  } catch (const std::invalid_argument& e) {
    in.fail(e.what());
  }
  const std::size_t nodes = in.count(16);
  if (nodes != m.solution.nodes.positions.size()) in.fail("the solves do not match the mesh's nodes");
  m.solution.g_x.resize(nodes), m.solution.g_y.resize(nodes);
  for (std::size_t i = 0; i < nodes; ++i) m.solution.g_x[i] = in.number(), m.solution.g_y[i] = in.number();
  for (SymmetricMatrix* k : {&m.solution.stiffness, &m.solution.line_x, &m.solution.line_y}) {
    k->size = int(nodes);
    const std::size_t entries = in.count(16);
    for (std::size_t e = 0; e < entries; ++e) {
      k->row.push_back(in.index(nodes)), k->col.push_back(in.index(nodes)), k->value.push_back(in.number());
      if (k->row.back() > k->col.back()) in.fail("a matrix entry below the diagonal");
    }
  }
  m.fold_free.low = in.number(), m.fold_free.high = in.number();
  if (!(m.fold_free.low < 1 && m.fold_free.high > 1)) in.fail("a fold-free range without the identity");
  in.expect_done();
  return m;
}

}  // namespace zoomwarp::warp
