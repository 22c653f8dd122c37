// Traditional zooming of a (possibly warped) image, the second half of every retargeting method
// ([ICAZ §6.1]'s Retargeting+Zooming; docs/algorithms.md "Common contract"): the image warped
// once to a target W'×H' is shown at a uniform scale from fit-to-screen (z = 0) to 1:1 (z = 1),
// centred on the view centre's warped position. Plain functions on plain data; thread-safe.
#pragma once

#include <array>
#include <vector>

#include "warp/core/mesh.h"
#include "warp/core/view.h"

namespace zoomwarp::warp {

// Requests come from the network: throws std::invalid_argument for non-finite numbers and for a
// screen beyond limits.h (kMaxScreenSide, kMaxScreenPixels).
void check_view_request(const ViewRequest& r);

// Barycentric coordinates of p in triangle (a, b, c), and the point with coordinates l in
// triangle (a, b, c).
std::array<double, 3> barycentric(const Point& p, const Point& a, const Point& b, const Point& c);
Point combine(const std::array<double, 3>& l, const Point& a, const Point& b, const Point& c);

// The triangle of `mesh` holding source point p, and p's barycentric coordinates in it: the first
// triangle (in mesh order) whose smallest coordinate is ≥ 0, else the one whose smallest
// coordinate is largest (points just outside the mesh, rounding); triangle −1 if none compares
// (no triangle of positive area). O(triangles); TriangleLocator (triangle_locator.h) answers the
// same for many points.
struct MeshPoint {
  int triangle = -1;
  std::array<double, 3> barycentric{};
};
MeshPoint locate_in(const Mesh& mesh, const Point& p);

// Where source point p lands in a warp of `mesh`: through the affine map of locate_in's triangle
// (p itself if there is none). O(triangles).
Point locate(const Mesh& mesh, const std::vector<Point>& warped, const Point& p);
Point locate(const Mesh& mesh, const std::vector<Point>& warped, const Point& p, const MeshPoint& where);

// The triangles of `mesh` whose screen bounding box meets the screen [0, sw] × [0, sh].
std::vector<int> visible_triangles(const Mesh& mesh, const std::vector<Point>& screen, double sw, double sh);

// Where traditional zoom puts warped point q on the screen: q·scale + (ox, oy) — the placement
// uniform_zoom computes, for a caller that needs the screen positions without a View.
struct ZoomPlacement {
  double scale = 1, ox = 0, oy = 0;
  bool centre_clamped = false;
  Point on_screen(const Point& q) const { return {q.x * scale + ox, q.y * scale + oy}; }
  std::vector<Point> on_screen(const std::vector<Point>& warped) const;
};
ZoomPlacement zoom_placement(double tw, double th, const ViewRequest& r, const Point& centre_warped);

// The request's view centre clamped to a width × height image.
Point request_centre(const ViewRequest& r, double width, double height);

// The View of image `warped` (a warp of `source` onto [0, tw] × [0, th]) under traditional zoom:
// scale from min(sw/tw, sh/th) at z = 0 to 1 at z = 1 along the request's curve; the view
// centre (`centre_warped`, warped pixels) goes to the screen centre, clamped so that no blank
// shows along an axis where the image is larger than the screen, centred (letterboxed) along an
// axis where it is smaller.
View uniform_zoom(const Mesh& source, const std::vector<Point>& warped, double tw, double th, const ViewRequest& r,
                  const Point& centre_warped);

// The same for a whole-image warp of a width × height image (every Retargeter's view): centred on
// where the request's centre, clamped to the image, lands in the warp.
View uniform_zoom_of_warp(const Mesh& source, const std::vector<Point>& warped, double tw, double th,
                          const ViewRequest& r, double width, double height);

}  // namespace zoomwarp::warp
