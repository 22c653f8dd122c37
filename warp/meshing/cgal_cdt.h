// The CGAL constrained Delaunay triangulation that coarse_mesh.cc and constrained_mesh.cc build on,
// and the kernel cvt_mesh.cc's Delaunay triangulation uses. Private to meshing/: include it first
// in those three files and nowhere else — it pulls in CGAL, whose headers are heavy.
//
// CGAL's own checks stay on even in release builds (NDEBUG and CGAL_NDEBUG are undefined before
// any CGAL header). Delaunay refinement of crossing line constraints — whose intersection points
// inexact constructions round — can meet a flat face (64 lines on a grid: "orientation(...) !=
// COLLINEAR" in Mesh_2/Refine_faces.h); without the checks it runs on into a null dereference
// and takes the process down. With them it throws CGAL::Failure_exception, which the callers
// refuse as bad input. Exact constructions were tried instead: the refinement then did not
// finish within 90 s.
#pragma once

#ifdef NDEBUG
#undef NDEBUG
#endif
#ifdef CGAL_NDEBUG
#undef CGAL_NDEBUG
#endif

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

namespace zoomwarp::warp::cgal_cdt {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<int, K>;  // info: the caller's vertex index
using Fb = CGAL::Delaunay_mesh_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
// Exact predicates: orientation tests are exact; crossing constraints are split at their
// intersection (coarse_mesh) or refused before meshing (constrained_mesh).
using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;

}  // namespace zoomwarp::warp::cgal_cdt
