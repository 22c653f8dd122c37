// method=mp [Guo09] as a Retargeter (methods/retargeter.h): the whole image mapped onto the
// screen's aspect ratio by mp_solve — salient objects scaled rigidly, the rest stretched toward
// the ideal lengths, lines kept straight — then traditional zoom into the result, as every method
// does (docs/algorithms.md, "Common contract").
//
// The model (mp_precompute.h) is in analysis pixels; a request's target W'×H' (the z = 0 target
// of ICAZ: the screen's aspect ratio, the image's area [ICAZ §5.1]) is solved in analysis pixels
// and scaled back per axis, so the boundary lands exactly on the target rectangle. Solves are
// cached for the kCachedSizes most recently used target sizes; a missing size starts warm from
// the cached solve of the nearest aspect ratio [Guo09 §3.4.2 needs a start; the nearby warp is
// one Newton polish away]. At the image's own aspect the warp is the identity, so zoom 1 is the
// plain crop.
//
// Thread safety: view() and memory_bytes() may be called concurrently; the model is read-only,
// the cache is under a mutex held while a missing size is solved (single flight).
#pragma once

#include <mutex>
#include <utility>
#include <vector>

#include "warp/methods/mp/mp_model.h"
#include "warp/methods/recent_cache.h"
#include "warp/methods/retargeter.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

class MpRetargeting final : public Retargeter {
 public:
  static constexpr int kCachedSizes = 16;

  // `width` × `height`: the full image. Throws std::invalid_argument for a model without a mesh
  // or sizes that are not positive.
  MpRetargeting(double width, double height, MpModel model);

  View view(const ViewRequest& request) override;
  std::size_t memory_bytes() override;

  // The model's mesh in image pixels.
  const Mesh& mesh() const { return mesh_; }
  const MpModel& model() const { return model_; }

 private:
  // One solve, in analysis pixels (the warm start of the next).
  struct Solved {
    double target_width = 0, target_height = 0;
    std::vector<Point> positions;
    WarpResult stats;
  };
  // The solve for a target of tw × th image pixels, from the cache or solved now.
  Solved warped(double tw, double th, const StopToken* stop);

  const double width_, height_;
  const MpModel model_;
  const Mesh mesh_;  // model_.mesh in image pixels
  std::mutex mu_;
  RecentCache<std::pair<long long, long long>, Solved> cache_{  // by size (1/1000 px)
      kCachedSizes, [](const Solved& s) { return s.positions.capacity() * sizeof(Point); }};
};

// The registry entry "mp": precompute builds the MpModel (mp.<saliency>.bin), load parses it.
const RetargetingMethod& mp_method();

}  // namespace zoomwarp::warp
