// The zoom evolution [ICAZ §5.1]: the zoom level z ∈ [0, 1] sets the target aspect ratio of
// the warp and the size of the viewing area, the part of the warped image shown on the screen.
//
//   z = 0: target aspect = the screen's, viewing area = the whole warped image (global view);
//   z = 1: target aspect = the image's (no distortion), viewing area = the screen (1:1 crop).
//
// The warped image keeps the source's area (W'·H' = W·H), so z = 1 is exactly the source size.
// Two curves: the paper's linear interpolation, and a geometric one for the viewing area whose
// magnification grows by the same factor for every equal step of z, so zoom steps feel equal.
#pragma once

namespace zoomwarp::warp {

enum class ZoomCurve { kLinear, kGeometric };

// What zoom 0 shows (`fit=`, warp/window/fit.h): the aspect ratio of the warp's target at z = 0,
// and whether traditional zoom of that target (core/uniform_zoom.h) starts from covering the
// screen, cropping what overflows, or from showing all of it with bands. The target aspect goes
// from `aspect` at z = 0 to the image's at z = 1, as the screen's did in [ICAZ §5.1]; the viewing
// area at z = 0 is the largest screen-shaped rectangle inside the target, which for a target of the
// screen's aspect is all of it.
//
//   fit=warp  aspect 0 (the screen's): the paper's global view, the whole image warped;
//   fit=auto  between the image's and the screen's, cover: warped within a distortion budget,
//             the overflow cropped where it matters least (window/view_window.h places it);
//   fit=crop, fit=pad  no warp: traditional zoom with cover, or without (bands).
// The default is what every view was before fit= (issue 41).
struct ZoomFrame {
  double aspect = 0;   // target width / height at z = 0; 0 (or not positive and finite): the screen's
  bool cover = false;  // traditional zoom's z = 0 covers the screen, cropping what overflows;
                       // false: it shows the whole target (bands where its aspect differs)
};

struct ZoomGeometry {
  double target_width = 0, target_height = 0;  // the warped image (the rectangle the warp fills)
  double view_width = 0, view_height = 0;      // the viewing area, in warped-image pixels
  double screen_scale = 1;                     // screen pixels per warped-image pixel
};

// The screen is screen_w × screen_h; the image W × H. z is clamped to [0, 1]. The viewing area
// fits inside the warped image (shrunk, keeping the screen's aspect, when the curve would make it
// larger), so the screen is covered — except that it is never shrunk below the screen itself
// (screen_scale > 1): along an axis where the warped image is then smaller than the viewing
// area, the view is letterboxed (centred, black bands). So z = 1 is the 1:1 crop on every image,
// also one smaller than the screen (a 1024×512 image on a 360×640 screen: 1:1 with 64 px bands
// above and below, not magnified ×1.25); for 0 < z < 1 the magnification follows the curve
// down to 1 and the bands appear once the image no longer fills the screen at that scale.
// With frame.aspect set, "the screen's aspect" at z = 0 above is frame.aspect, and the viewing area
// at z = 0 is the largest screen-shaped rectangle inside that target.
ZoomGeometry zoom_geometry(double image_w, double image_h, double screen_w, double screen_h, double z,
                           ZoomCurve curve = ZoomCurve::kGeometric, ZoomFrame frame = {});

// The aspect a frame asks for at z = 0: frame.aspect, or the screen's where it is 0 or not a
// positive finite number.
double frame_aspect(const ZoomFrame& frame, double screen_w, double screen_h);

// A quantity going from `at0` (z = 0) to `at1` (z = 1) along the curve: (1 − z)·at0 + z·at1, or
// at0·(at1/at0)^z — exactly at0 and at1 at the ends (at0·(at1/at0) need not be at1 in floating
// point, and z = 1 must be 1:1 to the bit: a 1024×512 image at 360×640 was drawn at scale
// 1 + 2⁻⁵², its letterbox one pixel off). z in [0, 1]; at0, at1 > 0 for the geometric curve.
double along_curve(double at0, double at1, double z, ZoomCurve curve);

}  // namespace zoomwarp::warp
