#include "warp/core/uniform_zoom.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "warp/core/limits.h"

namespace zoomwarp::warp {

// Barycentric coordinates of p in triangle (a, b, c).
std::array<double, 3> barycentric(const Point& p, const Point& a, const Point& b, const Point& c) {
  const double d = signed_area2(a, b, c);
  const double l0 = signed_area2(p, b, c) / d, l1 = signed_area2(a, p, c) / d;
  return {l0, l1, 1 - l0 - l1};
}

Point combine(const std::array<double, 3>& l, const Point& a, const Point& b, const Point& c) {
  return {l[0] * a.x + l[1] * b.x + l[2] * c.x, l[0] * a.y + l[1] * b.y + l[2] * c.y};
}

MeshPoint locate_in(const Mesh& mesh, const Point& p) {
  double best = -std::numeric_limits<double>::infinity();
  MeshPoint out;
  for (int f = 0; f < int(mesh.triangles.size()); ++f) {
    const Triangle& t = mesh.triangles[f];
    const auto l = barycentric(p, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
    const double inside = std::min({l[0], l[1], l[2]});
    if (inside > best) {
      best = inside;
      out = {f, l};
      if (inside >= 0) break;
    }
  }
  return out;
}

Point locate(const Mesh& mesh, const std::vector<Point>& warped, const Point& p, const MeshPoint& where) {
  if (where.triangle < 0) return p;
  const Triangle& t = mesh.triangles[where.triangle];
  return combine(where.barycentric, warped[t[0]], warped[t[1]], warped[t[2]]);
}

Point locate(const Mesh& mesh, const std::vector<Point>& warped, const Point& p) {
  return locate(mesh, warped, p, locate_in(mesh, p));
}

// Requests come from the network: refuse what no view can be made of rather than compute garbage.
void check_view_request(const ViewRequest& r) {
  if (!std::isfinite(r.zoom) || !std::isfinite(r.cx) || !std::isfinite(r.cy) || !std::isfinite(r.max_screen_area) ||
      r.max_screen_area < 1)
    throw std::invalid_argument("view request out of range");
  if (r.screen_width < 1 || r.screen_height < 1 || r.screen_width > limits::kMaxScreenSide ||
      r.screen_height > limits::kMaxScreenSide ||
      (long long)r.screen_width * r.screen_height > limits::kMaxScreenPixels)
    throw std::invalid_argument("screen size out of range");
}

// A triangle's screen bounding box misses the screen iff all three vertices lie on the far side
// of one screen edge: with one bit per edge per vertex (Cohen–Sutherland outcodes), iff the AND
// of its vertices' codes is not 0. The codes are computed once per vertex and fit in L1, so the
// loop over triangles reads three bytes each instead of six doubles scattered over the mesh.
std::vector<int> visible_triangles(const Mesh& mesh, const std::vector<Point>& screen, double sw, double sh) {
  std::vector<std::uint8_t> code(screen.size());
  for (std::size_t v = 0; v < screen.size(); ++v) {
    const Point& p = screen[v];
    code[v] = std::uint8_t((p.x <= 0) | (p.x >= sw) << 1 | (p.y <= 0) << 2 | (p.y >= sh) << 3);
  }
  std::vector<int> out;
  for (int f = 0; f < int(mesh.triangles.size()); ++f) {
    const Triangle& t = mesh.triangles[f];
    if ((code[t[0]] & code[t[1]] & code[t[2]]) == 0) out.push_back(f);
  }
  return out;
}

// Traditional zooming of a (possibly warped) image of size tw × th: uniform scale from
// fit-to-screen or cover-the-screen (z = 0, r.frame) to 1:1 (z = 1); the view centre goes to the screen centre, clamped so
// that no blank shows along an axis where the image is larger than the screen, and centred
// (letterboxed) along an axis where it is smaller.
ZoomPlacement zoom_placement(double tw, double th, const ViewRequest& r, const Point& centre_warped) {
  ZoomPlacement out;
  const double sw = r.screen_width, sh = r.screen_height, z = std::clamp(std::isfinite(r.zoom) ? r.zoom : 0.0, 0.0, 1.0);
  // z = 0 shows the whole image or covers the screen with it (ZoomFrame); for a target
  // of the screen's aspect the two are the same.
  const double fit = r.frame.cover ? std::max(sw / tw, sh / th) : std::min(sw / tw, sh / th);
  const double scale = along_curve(fit, 1, z, r.curve);
  auto axis = [&](double c, double size, double screen, bool* clamped) {
    const double extent = size * scale;
    if (extent <= screen) return (screen - extent) / 2;  // letterbox
    const double offset = screen / 2 - c * scale;
    const double clamped_offset = std::clamp(offset, screen - extent, 0.0);
    *clamped |= clamped_offset != offset;
    return clamped_offset;
  };
  out.scale = scale;
  out.ox = axis(centre_warped.x, tw, sw, &out.centre_clamped), out.oy = axis(centre_warped.y, th, sh, &out.centre_clamped);
  return out;
}

std::vector<Point> ZoomPlacement::on_screen(const std::vector<Point>& warped) const {
  std::vector<Point> out;
  out.reserve(warped.size());
  for (const Point& q : warped) out.push_back(on_screen(q));
  return out;
}

View uniform_zoom(const Mesh& source, const std::vector<Point>& warped, double tw, double th, const ViewRequest& r,
                  const Point& centre_warped) {
  View out;
  const ZoomPlacement place = zoom_placement(tw, th, r, centre_warped);
  const double sw = r.screen_width, sh = r.screen_height, scale = place.scale;
  out.centre_clamped = place.centre_clamped;
  out.geometry = {tw, th, sw / scale, sh / scale, scale};
  out.view_x = -place.ox / scale, out.view_y = -place.oy / scale;
  out.source = source;
  out.warped = warped;
  out.screen = place.on_screen(warped);
  out.visible = visible_triangles(source, out.screen, sw, sh);
  return out;
}

Point request_centre(const ViewRequest& r, double width, double height) {
  return {std::clamp(r.cx, 0.0, width), std::clamp(r.cy, 0.0, height)};
}

View uniform_zoom_of_warp(const Mesh& source, const std::vector<Point>& warped, double tw, double th,
                          const ViewRequest& r, double width, double height) {
  return uniform_zoom(source, warped, tw, th, r, locate(source, warped, request_centre(r, width, height)));
}

}  // namespace zoomwarp::warp
