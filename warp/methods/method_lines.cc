#include "warp/methods/method_lines.h"

namespace zoomwarp::warp {

std::vector<Segment> method_lines(const MethodInput& input) {
  const tiles::Raster& image = input.analysis_image;
  const double sx = double(image.width) / input.model.width, sy = double(image.height) / input.model.height;
  std::vector<Segment> out;
  const auto add = [&](const Segment& s) {
    if (auto c = clip_segment({{s.a.x * sx, s.a.y * sy}, {s.b.x * sx, s.b.y * sy}}, 0, 0, image.width, image.height))
      out.push_back(*c);
  };
  for (const Segment& s : input.lines) add(s);
  for (const Segment& s : input.detected_lines) add(s);
  return out;
}

}  // namespace zoomwarp::warp
