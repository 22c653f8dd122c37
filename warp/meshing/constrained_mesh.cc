// A CGAL translation unit (meshing/README.md, cgal_cdt.h): refinement that meets a flat face
// throws CGAL::Failure_exception (refused as bad input) instead of dereferencing null.
#include "warp/meshing/cgal_cdt.h"
#include "warp/meshing/constrained_mesh.h"

#include <CGAL/Delaunay_mesh_criteria_2.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>

namespace zoomwarp::warp {

namespace {

using cgal_cdt::CDT;
using cgal_cdt::K;
// Crossing constraints are refused before meshing (check_input), so CGAL never has to construct
// (and round) an intersection point.
using Criteria = CGAL::Delaunay_mesh_criteria_2<CDT>;
using Mesher = CGAL::Delaunay_mesher_2<CDT, Criteria>;

[[noreturn]] void refuse(const std::string& why) { throw std::invalid_argument("constrained mesh: " + why); }

K::Point_2 cgal(const Point& p) { return {p.x, p.y}; }

// Position along the border, clockwise on screen from (0, 0): top, right, bottom, left.
double perimeter_position(const Point& p, double w, double h) {
  if (p.y == 0) return p.x;
  if (p.x == w) return w + p.y;
  if (p.y == h) return w + h + (w - p.x);
  return 2 * w + h + (h - p.y);
}

bool on_border(const Point& p, double w, double h) { return p.x == 0 || p.y == 0 || p.x == w || p.y == h; }

bool along_border(const Point& a, const Point& b, double w, double h) {
  return (a.x == 0 && b.x == 0) || (a.y == 0 && b.y == 0) || (a.x == w && b.x == w) || (a.y == h && b.y == h);
}

void check_input(double w, double h, const std::vector<Point>& points,
                 const std::vector<std::array<int, 2>>& constraints) {
  if (!(std::isfinite(w) && std::isfinite(h) && w > 0 && h > 0)) refuse("the rectangle must have a positive size");
  std::vector<std::tuple<double, double, int>> sorted;
  for (int i = 0; i < int(points.size()); ++i) {
    const Point& p = points[i];
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && p.x >= 0 && p.x <= w && p.y >= 0 && p.y <= h))
      refuse("point " + std::to_string(i) + " is outside the rectangle");
    sorted.emplace_back(p.x, p.y, i);
  }
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 1; i < sorted.size(); ++i)
    if (std::get<0>(sorted[i]) == std::get<0>(sorted[i - 1]) && std::get<1>(sorted[i]) == std::get<1>(sorted[i - 1]))
      refuse("points " + std::to_string(std::get<2>(sorted[i - 1])) + " and " + std::to_string(std::get<2>(sorted[i])) +
             " are equal");

  const int n = int(points.size());
  for (const auto& [a, b] : constraints) {
    if (a < 0 || b < 0 || a >= n || b >= n || a == b) refuse("a constraint names a missing point or one point twice");
    if (along_border(points[a], points[b], w, h)) refuse("a constraint runs along the border");
  }
  // Pairwise, with a bounding-box test first: a few hundred constraints at most in practice.
  for (std::size_t i = 0; i < constraints.size(); ++i) {
    const Point &a = points[constraints[i][0]], &b = points[constraints[i][1]];
    for (std::size_t j = i + 1; j < constraints.size(); ++j) {
      const Point &c = points[constraints[j][0]], &d = points[constraints[j][1]];
      if (std::max(a.x, b.x) < std::min(c.x, d.x) || std::max(c.x, d.x) < std::min(a.x, b.x) ||
          std::max(a.y, b.y) < std::min(c.y, d.y) || std::max(c.y, d.y) < std::min(a.y, b.y))
        continue;
      const auto [i0, i1] = constraints[i];
      const auto [j0, j1] = constraints[j];
      const int shared = (i0 == j0 || i0 == j1) ? i0 : (i1 == j0 || i1 == j1) ? i1 : -1;
      bool bad = false;
      if (shared < 0) {
        bad = CGAL::do_intersect(K::Segment_2(cgal(a), cgal(b)), K::Segment_2(cgal(c), cgal(d)));
      } else if (i0 == j0 + j1 - shared && i1 == j0 + j1 - shared) {
        bad = true;  // the same constraint twice (either direction)
      } else {
        // Sharing one end, they meet elsewhere only when they overlap: collinear, same direction.
        const Point& s = points[shared];
        const Point& p = points[i0 + i1 - shared];
        const Point& q = points[j0 + j1 - shared];
        bad = CGAL::orientation(cgal(s), cgal(p), cgal(q)) == CGAL::COLLINEAR &&
              (p.x - s.x) * (q.x - s.x) + (p.y - s.y) * (q.y - s.y) > 0;
      }
      if (bad) refuse("constraints " + std::to_string(i) + " and " + std::to_string(j) + " cross or overlap");
    }
  }
}

Mesh triangulate(double w, double h, const std::vector<Point>& points,
                 const std::vector<std::array<int, 2>>& constraints, const ConstrainedMeshOptions& options) {
  std::vector<Point> all = points;
  for (const Point corner : {Point{0, 0}, Point{w, 0}, Point{w, h}, Point{0, h}})
    if (std::none_of(points.begin(), points.end(), [&](const Point& p) { return p.x == corner.x && p.y == corner.y; }))
      all.push_back(corner);

  CDT cdt;
  std::vector<CDT::Vertex_handle> handles;
  handles.reserve(all.size());
  for (const Point& p : all) handles.push_back(cdt.insert(cgal(p)));

  // The border through every point on it, so that the mesh's domain is exactly the rectangle.
  std::vector<std::pair<double, int>> border;
  for (int i = 0; i < int(all.size()); ++i)
    if (on_border(all[i], w, h)) border.emplace_back(perimeter_position(all[i], w, h), i);
  std::sort(border.begin(), border.end());
  for (std::size_t k = 0; k < border.size(); ++k)
    cdt.insert_constraint(handles[border[k].second], handles[border[(k + 1) % border.size()].second]);
  for (const auto& [a, b] : constraints) cdt.insert_constraint(handles[a], handles[b]);

  const double sine = std::sin(options.min_angle_degrees * M_PI / 180.0);
  Mesher mesher(cdt, Criteria(sine * sine));
  mesher.init();
  // Worst triangles are split first; the step bound guards against steps that insert nothing.
  const long long max_steps = 10LL * std::max(options.vertex_budget, 1) + 100;
  for (long long step = 0; step < max_steps && !mesher.is_refinement_done() &&
                           int(cdt.number_of_vertices()) < options.vertex_budget;
       ++step)
    mesher.step_by_step_refine_mesh();

  Mesh out;
  out.vertices = all;
  for (auto v : cdt.finite_vertex_handles()) v->info() = -1;
  for (int i = 0; i < int(handles.size()); ++i) handles[i]->info() = i;
  for (auto v : cdt.finite_vertex_handles())
    if (v->info() < 0) {
      v->info() = int(out.vertices.size());
      out.vertices.push_back({v->point().x(), v->point().y()});
    }
  for (auto f : cdt.finite_face_handles())
    if (f->is_in_domain())
      out.triangles.push_back({f->vertex(0)->info(), f->vertex(1)->info(), f->vertex(2)->info()});
  return out;
}

}  // namespace

Mesh build_constrained_mesh(double width, double height, const std::vector<Point>& points,
                            const std::vector<std::array<int, 2>>& constraints, const ConstrainedMeshOptions& options) {
  check_input(width, height, points, constraints);
  try {
    return triangulate(width, height, points, constraints, options);
  } catch (const CGAL::Failure_exception& e) {
    refuse(std::string("CGAL could not mesh the input: ") + e.what());
  }
}

}  // namespace zoomwarp::warp
