// method=polyfem for thin clients (METHODS §3, "Export"): the curved elements sampled into a
// triangle mesh that the bundled viewer and every renderer texture-map like ICAZ's. Each cell is
// fanned from its vertex centroid and every fan triangle cut into 4^level by a regular lattice;
// points on a cell edge (and on a spoke) are computed from the edge's ends alone, so neighbouring
// cells share them exactly (no cracks). A sample's warped position:
//
//   f(p) = p + ΔW·G_x(p)·e_x + ΔH·G_y(p)·e_y,   G = Σ_k B_k·g_k   (polyfem_system.h)
//
// inside a cell from the serendipity basis, on a cell edge from the 1-D P2 of its three nodes, at
// a vertex its node value — the same function, evaluated where each formula is defined.
//
// Thread safety: pure functions.
#pragma once

#include <vector>

#include "warp/core/mesh.h"
#include "warp/meshing/polygon_mesh.h"
#include "warp/methods/polyfem/polyfem_system.h"

namespace zoomwarp::warp {

// Where a sample lies: inside cell `cell`, on the edge between nodes (a, b) with midpoint node m
// at parameter t from a, or at vertex node a.
struct PolyfemSample {
  enum Kind { kInside, kOnEdge, kAtVertex } kind = kInside;
  Point source;
  int cell = -1;        // kInside
  int a = -1, b = -1, m = -1;  // kOnEdge: the edge's end nodes and midpoint node; kAtVertex: a
  double t = 0;
};

struct PolyfemSampling {
  Mesh mesh;                            // source positions, CCW triangles
  std::vector<PolyfemSample> samples;   // per mesh vertex
};

// The cells sampled at subdivision `level` (0: the fans themselves).
PolyfemSampling sample_polyfem_cells(const PolygonMesh& mesh, const PolyfemNodes& nodes, int level);

// G_x and G_y at every sample (dimensionless; cached per level by the caller).
struct SampledField {
  std::vector<double> g_x, g_y;
};
SampledField sample_polyfem_field(const PolygonMesh& mesh, const PolyfemSolution& solution,
                                  const PolyfemSampling& sampling);

// The samples' warped positions for a target: p + (ΔW·G_x, ΔH·G_y).
std::vector<Point> warp_polyfem_samples(const PolyfemSampling& sampling, const SampledField& field, double delta_w,
                                        double delta_h);

}  // namespace zoomwarp::warp
