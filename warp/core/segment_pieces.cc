#include "warp/core/segment_pieces.h"

#include <algorithm>
#include <cmath>

namespace zoomwarp::warp {

namespace {

// The interval of u where every barycentric coordinate of s(u) in triangle f is ≥ 0. The
// coordinates are affine in u; one that is 0 at both ends but for rounding means s runs along
// that edge, which then bounds nothing (the piece is in the triangles on both sides).
bool piece_in(const Mesh& mesh, const Segment& s, int f, SegmentPiece& out) {
  const Triangle& t = mesh.triangles[std::size_t(f)];
  const Point &a = mesh.vertices[std::size_t(t[0])], &b = mesh.vertices[std::size_t(t[1])], &c = mesh.vertices[std::size_t(t[2])];
  const double x0 = std::min(s.a.x, s.b.x), x1 = std::max(s.a.x, s.b.x);
  const double y0 = std::min(s.a.y, s.b.y), y1 = std::max(s.a.y, s.b.y);
  if (std::max({a.x, b.x, c.x}) < x0 || std::min({a.x, b.x, c.x}) > x1 || std::max({a.y, b.y, c.y}) < y0 ||
      std::min({a.y, b.y, c.y}) > y1 || signed_area2(a, b, c) == 0)
    return false;
  const auto l0 = barycentric(s.a, a, b, c), l1 = barycentric(s.b, a, b, c);
  double lo = 0, hi = 1;
  for (int k = 0; k < 3 && lo <= hi; ++k) {
    if (std::max(std::abs(l0[k]), std::abs(l1[k])) <= -kOnEdge) continue;  // along edge k
    const double slope = l1[k] - l0[k];  // l_k(u) = l0[k] + u·slope ≥ 0
    if (slope == 0) {
      if (l0[k] < 0) return false;
    } else if (slope > 0) {
      lo = std::max(lo, -l0[k] / slope);
    } else {
      hi = std::min(hi, -l0[k] / slope);
    }
  }
  if (lo > hi) return false;
  out = {f, lo, hi};
  return true;
}

void sort_pieces(std::vector<SegmentPiece>& pieces) {
  std::sort(pieces.begin(), pieces.end(), [](const SegmentPiece& p, const SegmentPiece& q) {
    return p.lo != q.lo ? p.lo < q.lo : p.hi != q.hi ? p.hi < q.hi : p.triangle < q.triangle;
  });
}

}  // namespace

std::vector<SegmentPiece> segment_pieces(const Mesh& mesh, const Segment& s, const std::vector<int>& among) {
  std::vector<SegmentPiece> out;
  SegmentPiece piece;
  for (int f : among)
    if (piece_in(mesh, s, f, piece)) out.push_back(piece);
  sort_pieces(out);
  return out;
}

std::vector<SegmentPiece> segment_pieces(const Mesh& mesh, const Segment& s) {
  std::vector<SegmentPiece> out;
  SegmentPiece piece;
  for (int f = 0; f < int(mesh.triangles.size()); ++f)
    if (piece_in(mesh, s, f, piece)) out.push_back(piece);
  sort_pieces(out);
  return out;
}

MeshPoint piece_point(const Mesh& mesh, const Segment& s, const SegmentPiece& piece, double u) {
  const Triangle& t = mesh.triangles[std::size_t(piece.triangle)];
  const Point p{s.a.x + u * (s.b.x - s.a.x), s.a.y + u * (s.b.y - s.a.y)};
  return {piece.triangle, barycentric(p, mesh.vertices[std::size_t(t[0])], mesh.vertices[std::size_t(t[1])],
                                      mesh.vertices[std::size_t(t[2])])};
}

}  // namespace zoomwarp::warp
