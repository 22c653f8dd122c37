// Where a segment runs through a triangle mesh: its piece inside each triangle. A piecewise-affine
// warp carries each piece to a straight piece, so the warped segment is exactly the polyline
// through its pieces' warped ends. What keeps a line straight (ShapeWarp's line term) and what
// measures its bend (compare's line_px) both start from these pieces (issue 30).
//
// Thread safety: plain functions.
#pragma once

#include <vector>

#include "warp/core/mesh.h"
#include "warp/core/uniform_zoom.h"

namespace zoomwarp::warp {

// A barycentric coordinate at least this is inside a triangle: on a shared edge rounding leaves a
// coordinate a hair (~1e-16 × extent / height) below 0.
inline constexpr double kOnEdge = -1e-9;

// Segment s(u) = s.a + u·(s.b − s.a) inside `triangle` for u in [lo, hi] ⊆ [0, 1].
struct SegmentPiece {
  int triangle = -1;
  double lo = 0, hi = 0;
};

// The pieces of s in the triangles `among` (indices into mesh.triangles), ordered by lo then hi.
// A piece may be a single point (lo == hi: s touches a corner or ends on an edge). A segment along
// an edge has a piece in the triangles on both sides. Degenerate triangles have none.
std::vector<SegmentPiece> segment_pieces(const Mesh& mesh, const Segment& s, const std::vector<int>& among);

// The same over every triangle of the mesh.
std::vector<SegmentPiece> segment_pieces(const Mesh& mesh, const Segment& s);

// The point s(u) of `piece` as a MeshPoint of its triangle.
MeshPoint piece_point(const Mesh& mesh, const Segment& s, const SegmentPiece& piece, double u);

}  // namespace zoomwarp::warp
