#include "warp/core/zoom_curve.h"

#include <algorithm>
#include <cmath>

namespace zoomwarp::warp {

double frame_aspect(const ZoomFrame& frame, double sw, double sh) {
  return std::isfinite(frame.aspect) && frame.aspect > 0 ? frame.aspect : sw / sh;
}

ZoomGeometry zoom_geometry(double W, double H, double sw, double sh, double z, ZoomCurve curve, ZoomFrame frame) {
  z = std::clamp(std::isfinite(z) ? z : 0.0, 0.0, 1.0);
  const double screen_aspect = sw / sh, image_aspect = W / H, aspect0 = frame_aspect(frame, sw, sh);
  const double aspect = (1 - z) * aspect0 + z * image_aspect;
  ZoomGeometry g;
  g.target_width = std::sqrt(W * H * aspect);
  g.target_height = std::sqrt(W * H / aspect);
  // The z = 0 viewing area: the screen-shaped rectangle inside the z = 0 target; with the screen's
  // aspect, the whole target (the paper's global view).
  const double full_view_w = aspect0 == screen_aspect
                                 ? std::sqrt(W * H * screen_aspect)
                                 : std::min(std::sqrt(W * H * aspect0), std::sqrt(W * H / aspect0) * screen_aspect);
  double view_w = along_curve(full_view_w, sw, z, curve);
  // Fit the viewing area inside the warped image, but never shrink it below the screen (a
  // magnification above 1): an image smaller than the screen is letterboxed instead, so z = 1 is
  // 1:1 on every image. Both bounds are continuous in z, and so is the curve.
  view_w = std::min({view_w, std::max(g.target_width, sw), std::max(g.target_height, sh) * screen_aspect});
  g.view_width = view_w;
  g.view_height = view_w / screen_aspect;
  g.screen_scale = sw / view_w;
  return g;
}

double along_curve(double at0, double at1, double z, ZoomCurve curve) {
  if (z <= 0) return at0;
  if (z >= 1) return at1;
  return curve == ZoomCurve::kLinear ? (1 - z) * at0 + z * at1 : at0 * std::pow(at1 / at0, z);
}

}  // namespace zoomwarp::warp
