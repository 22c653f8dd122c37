// method=mp: retargeting by mesh parametrization [Guo09], with [Kumar (004)]'s saliency objects
// for saliency=gbvs (docs/algorithms.md, "mp"). The precomputation as plain data (libigl style),
// shared by the two halves of the method:
//
//   mp_precompute.h   MethodInput → MpModel: feature points, the constrained Delaunay mesh
//                     (meshing/), rigid objects, lines, object-length tables; serialised
//                     as mp.<saliency>.bin
//   mp_solve.h        MpModel × target size → warped vertex positions: the stretch energy with
//                     ideal edge lengths [Guo09 eqs 8–10, 15], rigid objects [eq. 3], the line
//                     term (cross-product form, METHODS §1; ours: over the whole line), Newton
//                     with a per-edge PSD-projected Hessian and a fold-free line search
//
// Everything is in analysis pixels (the analysis image, long side ≤ 1024 px); the Retargeter
// scales by 1/σa (every energy is homogeneous of degree 2, so this is exact).
#pragma once

#include <vector>

#include "warp/core/corner_point.h"
#include "warp/core/mesh.h"

namespace zoomwarp::warp {

// A salient object moved rigidly: Q_i = Q_O + z·(P_i − P_O) for its vertices [Guo09 eq. 3].
// No vertex belongs to two objects.
struct MpObject {
  std::vector<int> vertices;  // mesh vertices of the object (its triangles' corners)
  Point pole;                 // P_O: the mean of its vertices
  double area = 0;            // A_O, analysis px²
};

// A point of a line, written in the source triangle that holds it (core/corner_point.h; ours,
// issue 30).
using MpLinePoint = CornerPoint;

// A line kept straight: points along its whole segment, in order, its two ends first and last —
// samples every ≤ d/4 and the vertices of its chains of mesh edges, which stop short of the border
// and of the lines it crosses (mp_precompute.h). Ours, issue 30: the points between the chains,
// written barycentrically, hold the line where no edge does.
struct MpLine {
  std::vector<MpLinePoint> points;
};

struct MpModel {
  double width = 0, height = 0;  // the analysis image, Wa × Ha
  Mesh mesh;                     // analysis px, CCW triangles, boundary vertices on the rectangle
  std::vector<MpObject> objects;
  std::vector<MpLine> lines;
  // Total object length on each analysis row y (Lr, size Ha) and column x (Lc, size Wa), from the
  // objects' rasterised masks [Guo09 eq. 8–9].
  std::vector<double> row_object_length, column_object_length;
};

}  // namespace zoomwarp::warp
