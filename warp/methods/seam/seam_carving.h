// method=seam: seam carving [Avidan07] as a retargeting method, the baseline of [Kumar (004)
// §III-D] and of [Guo09 §4.1]'s user study. It removes pixels instead of moving them, so it has no
// mesh: /mesh answers 501 and only render() shows it.
//
//   precompute  both visibility maps of the analysis image reduced to a long side ≤ 512 px
//               (seam_resolution.h, visibility_map.h), the saliency map as liblqr's bias,
//               stored as seam.<saliency>.bin (uint16 per map pixel and axis);
//   request     the target keeps one side and shrinks the other to the screen's aspect —
//               W_s = min(W, H·sw/sh), H_s = min(H, W·sh/sw), removal only — by removing
//               k = L_a − round(σ_a·T) seams from the maps' image (σ_a map px per image
//               px); below a tenth of the side the recorded seams run out and the kept lines are
//               scaled to fill T. Then traditional zoom (core/uniform_zoom.h) into the carved
//               W_s × H_s image, centred on the view centre's carved position.
//
// A kept analysis pixel stands for a strip 1/σ_a image pixels wide: a screen pixel maps to a
// carved point, to the kept analysis position on its line with the fraction carried through, to
// a full-resolution source point sampled from the pyramid level the screen's scale needs — so at
// high zoom every kept strip shows full detail. Equal aspects remove nothing: the identity, and
// zoom 1 is the plain crop.
//
// Thread safety: SeamCarving is thread-safe (its carve-table cache is under a mutex; the maps
// are immutable).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include "warp/methods/recent_cache.h"
#include "warp/methods/retargeting_method.h"
#include "warp/methods/seam/visibility_map.h"

namespace zoomwarp::warp {

// The registry entry (methods/registry.cc).
const RetargetingMethod& seam_carving_method();

// seam.<saliency>.bin's payload (after the magic) and back; parse throws std::runtime_error for
// bytes that are not two well-formed maps.
std::string visibility_map_bytes(const VisibilityMaps& maps);
VisibilityMaps parse_visibility_maps(std::string_view bytes);

// The image carved to one screen's aspect: which analysis positions each line keeps and how they
// fill the target. Image pixels on both sides.
struct CarvedImage {
  double width = 0, height = 0;  // W_s × H_s
  bool vertical = false;         // rows are removed (false: columns)
  double source_length = 0;      // W (H when vertical), image px
  int analysis_length = 0;       // L_a
  int analysis_lines = 0;        // the analysis side across
  int seams = 0;                 // k
  std::shared_ptr<const CarveTable> table;

  // The source point shown at carved point p (inside [0, W_s] × [0, H_s]).
  Point to_source(const Point& p) const;
  // to_source in parts, for a renderer that reuses them along a screen row or column: the
  // analysis line at `across` (carved = source coordinate across the carved axis), the kept index
  // and the fraction within it at carved coordinate `along`, and the source coordinate they give.
  struct Kept {
    int index = 0;
    double fraction = 0;
  };
  int line_at(double across) const;
  Kept kept_at(double along) const;
  double source_along(int line, const Kept& kept) const;
  // The source rectangle (image px) that carved rectangle [x0, x1] × [y0, y1] is drawn from.
  struct Box {
    double u0, v0, u1, v1;
  };
  Box source_box(double x0, double y0, double x1, double y1) const;
  // The carved position of source point p (a removed pixel: where its line's next kept one is).
  Point from_source(const Point& p) const;
};

class SeamCarving final : public Retargeter {
 public:
  // `width` × `height`: the full image; `maps` made from its analysis image.
  SeamCarving(double width, double height, VisibilityMaps maps);

  bool has_mesh() const override { return false; }
  // Throws NoMesh: seam carving removes pixels, there is no mesh to send.
  View view(const ViewRequest& request) override;
  // Exactly screen_width × screen_height. Throws std::invalid_argument for a request out of range
  // (check_view_request), Stopped, std::runtime_error when the pyramid cannot be read.
  tiles::Raster render(const ViewRequest& request, const tiles::ImageEntry& image,
                       tiles::PyramidReader& reader) override;
  std::vector<Point> screen_sources(const ViewRequest& request) override;
  std::size_t memory_bytes() override;

  // The carving to a target of aspect ratio sw / sh — a screen's, or a request's ZoomFrame's
  // (its carve table cached, the 8 most recent kept).
  CarvedImage carved(double sw, double sh);

 private:
  // Where a request's screen pixels come from: the carving, the zoom into it, and per screen
  // row and column what the carving needs of it — along the carved axis the kept index and
  // fraction, across it the analysis line (−1 outside the carved image: letterbox) — so a pixel
  // is one table read. source_of(x, y) is the image point shown at pixel (x, y), if any.
  struct ScreenLayout {
    CarvedImage carved;
    View zoom;
    std::vector<CarvedImage::Kept> kept;
    std::vector<int> line;
    std::vector<double> across;
    bool source_of(int x, int y, Point* p) const;
  };
  ScreenLayout layout(const ViewRequest& request);

  std::shared_ptr<const CarveTable> table(bool vertical, int seams);

  const double width_, height_;
  const VisibilityMaps maps_;
  std::mutex mu_;
  // By (vertical, seams); the 8 most recent.
  RecentCache<std::pair<bool, int>, std::shared_ptr<const CarveTable>> tables_{
      8, [](const std::shared_ptr<const CarveTable>& t) { return t->bytes(); }};
};

}  // namespace zoomwarp::warp
