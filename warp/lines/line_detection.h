// Automatic line detection [Guo09 §3.3.3]: strong straight edges of the image, found with Canny
// and the probabilistic Hough transform [Hough/Canny via OpenCV] on the analysis image (long side
// ≤ 1024 px), offered to the curator as suggested line constraints and used by `lines=auto`
// (ICAZ) and by methods that take detected lines (MethodInput::detected_lines).
//
//   1. Canny on the grey image, blurred (5×5 Gaussian) so that texture and noise vote less;
//   2. cv::HoughLinesP pieces down to L/4, L = max(0.1·min(Wa, Ha), 10 px) [Guo09 §3.3.3: "0.1
//      fold of the minimum of w_s and h_s"; the 10 px floor is ours, for small images]; each
//      piece refitted (total least squares) to the Canny pixels within 2 px of it (ours: Hough's
//      walk splits a tilted edge into pieces whose end points are off by a pixel or two);
//   3. pieces kept only where the image has an edge across them (ours: in texture and noise,
//      Canny's pixels are dense enough for Hough to find straight runs in every direction): at
//      least 75 % of the pixel steps along the piece have, within 1 px, a gradient of at least
//      Canny's low threshold within 22.5° of the piece's normal;
//   4. near-duplicates merged [Guo09: "only one segment is reserved if several segments are close
//      enough"; what "close" means is ours, see lies_along] into their span along the longer,
//      with d = sqrt(Wa·Ha/300), the point spacing of [Guo09 §3.2] for N = 300;
//   5. what is at least L long, not along the image border (ours: the border is straight under
//      every warp) and still an edge across its whole length (step 3 again: pieces of texture
//      that line up by chance leave gaps) is kept;
//   6. longest first, at most limits::kMaxLines segments of summed length at most
//      limits::kMaxTotalLineLength × the image's larger side: the curator's limits, so that any
//      suggestion set is also a valid line set (api PUT /lines) with the same bounded cost.
//
// Thread safety: pure functions, safe to call concurrently.
#pragma once

#include <vector>

#include "tiles/raster.h"
#include "warp/core/mesh.h"

namespace zoomwarp::warp {

struct LineDetectionOptions {
  double min_length_fraction = 0.1;  // of min(Wa, Ha) [Guo09 §3.3.3]
  double min_length_floor = 10;      // analysis px
  double duplicate_angle_degrees = 2;
  int point_count = 300;             // N of d = sqrt(Wa·Ha/N) [Guo09 §3.2]
};

// Segments in image pixels (of an image_width × image_height image) found in `analysis`, a
// reduced copy of the whole image (1–4 channels), longest first. Images whose smaller side is
// under 32 px give none (OpenCV is not called).
std::vector<Segment> detect_lines(const tiles::Raster& analysis, double image_width, double image_height,
                                  const LineDetectionOptions& options = {});

// Whether `s` lies along `line` [Guo09 §3.3.3, "close enough"; the criterion is ours]: their
// directions within max_angle (radians), both ends of s within max_offset of line's line, and
// s's projection onto it overlapping line or within max_offset of it.
bool lies_along(const Segment& s, const Segment& line, double max_offset, double max_angle);

// Whether a and b are the same segment within `tolerance` px at both ends, in either direction.
bool same_segment(const Segment& a, const Segment& b, double tolerance);

// How far a dismissed segment may be from a detected one and still name it (image px): the
// client sends back the coordinates it was given.
inline constexpr double kSameSegmentTolerance = 1;

// The parts of `s` at least `clearance` px from every segment of `others`, each at least
// `min_length` long, in order along s (ours, for lines=auto: CGAL's conforming refinement can fail
// or run without end where constraints cross or nearly touch — coarse_mesh.h — so a suggestion
// is cut back from every line it would cross or touch; it stays straight where it remains).
std::vector<Segment> clear_pieces(const Segment& s, const std::vector<Segment>& others, double clearance,
                                  double min_length);

// The suggestions left for the curator of an image_width × image_height image: `detected`
// without those the curator dismissed (same_segment) and without those that lie along one of
// the curator's lines (lies_along, with d/2 and the angle of the detector's duplicate test in
// image pixels): an accepted suggestion simply became a curator line, and a suggestion along a
// line the curator drew would only duplicate it. Order kept.
std::vector<Segment> remaining_suggestions(const std::vector<Segment>& detected, const std::vector<Segment>& curator,
                                           const std::vector<Segment>& dismissed, double image_width,
                                           double image_height, const LineDetectionOptions& options = {});

}  // namespace zoomwarp::warp
