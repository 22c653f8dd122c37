// The only translation unit that includes CGAL (it is header-heavy: keeping it here keeps the build fast).
//
// CGAL's own checks stay on here even in release builds. Delaunay refinement of crossing line
// constraints — whose intersection points inexact constructions round — can meet a flat face
// (64 lines on a grid: "orientation(...) != COLLINEAR" in Mesh_2/Refine_faces.h); without the
// checks it runs on into a null dereference and takes the process down. With them it throws
// CGAL::Failure_exception, refused below as bad input. Exact constructions were tried instead:
// the refinement then did not finish within 90 s.
#ifdef NDEBUG
#undef NDEBUG
#endif
#ifdef CGAL_NDEBUG
#undef CGAL_NDEBUG
#endif
#include "warp/meshing/coarse_mesh.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_size_criteria_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

namespace zoomwarp::warp {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<int, K>;
using Fb = CGAL::Delaunay_mesh_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
// Exact_predicates_tag: crossing line constraints are split at their intersection.
using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;
using Criteria = CGAL::Delaunay_mesh_size_criteria_2<CDT>;

// Liang–Barsky clipping of a segment to [0, w] × [0, h].
std::optional<Segment> clip(Segment s, double w, double h) {
  double t0 = 0, t1 = 1;
  const double dx = s.b.x - s.a.x, dy = s.b.y - s.a.y;
  const double p[4] = {-dx, dx, -dy, dy}, q[4] = {s.a.x, w - s.a.x, s.a.y, h - s.a.y};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0) {
      if (q[i] < 0) return std::nullopt;
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0) t0 = std::max(t0, t);
    else t1 = std::min(t1, t);
  }
  if (t0 >= t1) return std::nullopt;
  return Segment{{s.a.x + t0 * dx, s.a.y + t0 * dy}, {s.a.x + t1 * dx, s.a.y + t1 * dy}};
}

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
    auto c = clip(s, width, height);
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
