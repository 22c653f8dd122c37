// method=polyfem for thin clients (METHODS §3, "Export"): the curved elements sampled into
// triangles that the bundled viewer and every renderer texture-map like ICAZ's. A cell at level k
// is fanned from its vertex centroid and every fan triangle cut into 4^k by a regular lattice.
// Every sample carries its weights over the global nodes, so that with node displacements d
// (the axpy (ΔW·g_x, ΔH·g_y), or the fallback's) its warped position is
//
//   f(p) = p + Σ_k w_k(p)·d_k,   w_k = B_k(p)   (polyfem_system.h)
//
// with w from the serendipity basis inside a cell, from the 1-D P2 of the edge's three nodes on a
// cell edge (ordered from the lower vertex id, t measured from it), 1 at a vertex — the same
// function, evaluated where each formula is defined. Two cells compute a shared edge's samples
// from the same numbers in the same order, so their warped positions are bitwise equal and the
// cells can be sampled, cached and emitted one at a time without cracks. With d = 0 every sample
// is exactly its source point.
//
// Thread safety: pure functions.
#pragma once

#include <array>
#include <vector>

#include "warp/core/mesh.h"
#include "warp/meshing/polygon_mesh.h"
#include "warp/methods/polyfem/polyfem_system.h"

namespace zoomwarp::warp {

constexpr int kMaxPolyfemLevel = 6;

// One cell sampled at one level.
struct CellSampling {
  std::vector<Point> source;        // analysis px
  std::vector<Triangle> triangles;  // CCW, indices into source
  // Sample i: weights weight[j] on nodes node[j] for j in [offset[i], offset[i + 1]).
  std::vector<int> offset, node;
  std::vector<double> weight;
  // Level ≥ 1: every lattice edge of the level below as (end, midpoint, end), indices into source
  // — what its chord error is measured on (polyfem_chord_deviation).
  std::vector<std::array<int, 3>> chords;
  std::size_t memory_bytes() const;
};

// Throws std::invalid_argument for a level outside 0 … kMaxPolyfemLevel.
CellSampling sample_polyfem_cell(const PolygonMesh& mesh, const PolyfemNodes& nodes, int cell, int level);

// The number of triangles sample_polyfem_cell emits: fan triangles × 4^level.
long polyfem_cell_triangles(const PolygonMesh& mesh, int cell, int level);

// Appends the samples' warped positions p + Σ w·d to `out`; `displacement` per node.
void displace_cell_samples(const CellSampling& sampling, const std::vector<Point>& displacement,
                           std::vector<Point>& out);

// The node weights of point p of cell `cell` (on its boundary: the edge's 1-D P2), appended to
// node/weight. For evaluation at arbitrary points (tests check the samplings against it).
void polyfem_point_weights(const PolygonMesh& mesh, const PolyfemNodes& nodes, int cell, const Point& p,
                           std::vector<int>& node, std::vector<double>& weight);

// The chord error of the cell one level below `finer` (finer.level ≥ 1) under a displacement
// field: per axis, the largest distance of the displacement at a lattice edge's midpoint from the
// mean of its ends — how far that edge's straight chord misses the deformed curve. With
// `displacement` = (g_x, g_y) this is δ_c of G, and (ΔW·δ.x, ΔH·δ.y) bounds the axpy's miss
// (polyfem_system.h); with a fallback's displacement, its own miss. Measured at the level, not
// extrapolated: near a cell vertex the mean value coordinates bend faster, and δ shrinks only
// about twofold per level there (fourfold elsewhere).
Point polyfem_chord_deviation(const CellSampling& finer, const std::vector<Point>& displacement);

// polyfem_chord_deviation of sample_polyfem_cell(mesh, nodes, cell, k + 1) for k = 0 … levels − 1,
// the same numbers to the bit, from one sampling at `levels` (whose lattice holds every coarser
// one's points): δ_c per level for the model (polyfem_model.h) at about 3/4 of the cost.
// Throws std::invalid_argument unless 1 ≤ levels ≤ kMaxPolyfemLevel.
std::vector<Point> polyfem_chord_deviations(const PolygonMesh& mesh, const PolyfemNodes& nodes, int cell, int levels,
                                            const std::vector<Point>& displacement);

}  // namespace zoomwarp::warp
