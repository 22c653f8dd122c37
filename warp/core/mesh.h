// A triangle mesh as plain data (libigl style): vertex positions and counter-clockwise index
// triples, in image pixels with y pointing down. "Counter-clockwise" is meant in that frame:
// signed_area() > 0 for every triangle of a valid mesh.
#pragma once

#include <array>
#include <optional>
#include <vector>

namespace zoomwarp::warp {

struct Point {
  double x = 0, y = 0;
};

using Triangle = std::array<int, 3>;

struct Mesh {
  std::vector<Point> vertices;
  std::vector<Triangle> triangles;
};

// A straight segment in image pixels, e.g. a line constraint.
struct Segment {
  Point a, b;
};

// Twice the signed area of triangle (a, b, c): positive when a→b→c turns clockwise on screen
// (y down), which is counter-clockwise in the usual y-up frame.
inline double signed_area2(const Point& a, const Point& b, const Point& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// The part of segment s inside the rectangle [x0, x1] × [y0, y1] (Liang–Barsky), or nothing.
std::optional<Segment> clip_segment(const Segment& s, double x0, double y0, double x1, double y1);

// The vertices of `mesh` lying on segment s (within rounding), ordered from s.a to s.b. Mesh
// refinement only ever adds midpoints of constrained edges, so this recovers a line's chain.
std::vector<int> vertices_on_segment(const Mesh& mesh, const Segment& s);

inline double signed_area(const Mesh& m, const Triangle& t, const std::vector<Point>& positions) {
  return 0.5 * signed_area2(positions[t[0]], positions[t[1]], positions[t[2]]);
}

}  // namespace zoomwarp::warp
