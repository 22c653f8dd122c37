#include "warp/core/zoom_curve.h"

#include <algorithm>
#include <cmath>

namespace zoomwarp::warp {

ZoomGeometry zoom_geometry(double W, double H, double sw, double sh, double z, ZoomCurve curve) {
  z = std::clamp(std::isfinite(z) ? z : 0.0, 0.0, 1.0);
  const double screen_aspect = sw / sh, image_aspect = W / H;
  const double aspect = (1 - z) * screen_aspect + z * image_aspect;
  ZoomGeometry g;
  g.target_width = std::sqrt(W * H * aspect);
  g.target_height = std::sqrt(W * H / aspect);
  const double full_view_w = std::sqrt(W * H * screen_aspect);  // the whole z = 0 target
  double view_w = curve == ZoomCurve::kLinear ? (1 - z) * full_view_w + z * sw
                                              : full_view_w * std::pow(sw / full_view_w, z);
  // Fit the viewing area inside the warped image, but never shrink it below the screen (a
  // magnification above 1): an image smaller than the screen is letterboxed instead, so z = 1 is
  // 1:1 on every image. Both bounds are continuous in z, and so is the curve.
  view_w = std::min({view_w, std::max(g.target_width, sw), std::max(g.target_height, sh) * screen_aspect});
  g.view_width = view_w;
  g.view_height = view_w / screen_aspect;
  g.screen_scale = sw / view_w;
  return g;
}

}  // namespace zoomwarp::warp
