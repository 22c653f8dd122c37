// The coarsest mesh (meshing/README.md): a CGAL translation unit, see cgal_cdt.h for why CGAL's
// checks stay on and how a refinement that meets a flat face is refused.
#include "warp/meshing/cgal_cdt.h"
#include "warp/meshing/coarse_mesh.h"

#include <CGAL/Delaunay_mesh_size_criteria_2.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

namespace zoomwarp::warp {

namespace {

using cgal_cdt::CDT;
using cgal_cdt::K;
// Crossing line constraints are split at their intersection.
using Criteria = CGAL::Delaunay_mesh_size_criteria_2<CDT>;

CoarseMesh triangulate(double w, double h, const std::vector<std::optional<Segment>>& lines, double max_area,
                       double min_angle_degrees) {
  CDT cdt;
  const K::Point_2 corners[4] = {{0, 0}, {w, 0}, {w, h}, {0, h}};
  for (int i = 0; i < 4; ++i) cdt.insert_constraint(corners[i], corners[(i + 1) % 4]);
  for (const auto& l : lines)
    if (l) cdt.insert_constraint(K::Point_2(l->a.x, l->a.y), K::Point_2(l->b.x, l->b.y));

  // The size criterion bounds the longest edge; an equilateral triangle of that edge has the
  // largest area, so bounding the edge by sqrt(4A/√3) keeps every triangle under A.
  const double edge = std::sqrt(4.0 * max_area / std::sqrt(3.0));
  const double sine = std::sin(min_angle_degrees * M_PI / 180.0);
  CGAL::refine_Delaunay_mesh_2(cdt, Criteria(sine * sine, edge));

  CoarseMesh out;
  out.max_triangle_area = max_area;
  int index = 0;
  for (auto v : cdt.finite_vertex_handles()) {
    v->info() = index++;
    out.mesh.vertices.push_back({v->point().x(), v->point().y()});
  }
  for (auto f : cdt.finite_face_handles())
    if (f->is_in_domain())
      out.mesh.triangles.push_back({f->vertex(0)->info(), f->vertex(1)->info(), f->vertex(2)->info()});

  // Vertices on each line, ordered along it: the mesher only ever splits constrained edges.
  for (const auto& l : lines) out.line_vertices.push_back(l ? vertices_on_segment(out.mesh, *l) : std::vector<int>());
  return out;
}

CoarseMesh checked_triangulate(double w, double h, const std::vector<std::optional<Segment>>& lines, double max_area,
                               double min_angle_degrees) {
  try {
    return triangulate(w, h, lines, max_area, min_angle_degrees);
  } catch (const CGAL::Failure_exception&) {
    throw std::invalid_argument("the line constraints cross too closely to be meshed; move them apart");
  }
}

}  // namespace

CoarseMesh build_coarse_mesh(double width, double height, const std::vector<Segment>& lines,
                             const CoarseMeshOptions& options) {
  std::vector<std::optional<Segment>> clipped;
  for (const Segment& s : lines) {
    auto c = clip_segment(s, 0, 0, width, height);
    if (c && std::hypot(c->b.x - c->a.x, c->b.y - c->a.y) < 1.0) c.reset();
    clipped.push_back(c);
  }
  // Start from the larger of the requested area and the area the budget allows (a Delaunay
  // mesh at area A has about width·height/A triangles, half as many vertices), then grow the
  // area until the budget holds: line constraints and the angle bound add vertices.
  double area = std::max(options.max_triangle_area, width * height / (1.6 * options.vertex_budget));
  while (true) {
    CoarseMesh m = checked_triangulate(width, height, clipped, area, options.min_angle_degrees);
    if (int(m.mesh.vertices.size()) <= options.vertex_budget || area >= width * height) return m;
    area *= 1.25 * double(m.mesh.vertices.size()) / options.vertex_budget;
  }
}

}  // namespace zoomwarp::warp
