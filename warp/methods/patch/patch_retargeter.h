// method=patch [Lin13] as a Retargeter (methods/retargeter.h): the whole image mapped onto the
// screen's aspect ratio — the grid's positions W'·V_W + H'·V_H, one axpy over the precomputed
// solves (patch_energy.h) — then traditional zoom into the result, as every method does
// (docs/algorithms.md, "Common contract").
//
// If a target makes a triangle fold (the energy has no fold term: [Lin13] relies on D_LT and
// D_OR), the positions are blended towards the uniform stretch as little as needed
// (core/fold_blend.h); the View's coarse_stats.affine_blend reports how far. At the image's own
// aspect the warp is the identity, so zoom 1 is the plain crop.
//
// Thread safety: everything is read-only after construction; view() may run concurrently.
#pragma once

#include "warp/methods/patch/patch_precompute.h"
#include "warp/methods/retargeter.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

class PatchRetargeting final : public Retargeter {
 public:
  // `width` × `height`: the full image. Throws std::invalid_argument for sizes that are not
  // positive or a model whose bases do not match its grid.
  PatchRetargeting(double width, double height, PatchModel model);

  View view(const ViewRequest& request) override;
  std::size_t memory_bytes() override;

  // The grid as a mesh in image pixels.
  const Mesh& mesh() const { return mesh_; }

  // The warp onto tw × th image pixels (positions in image pixels) and its blend factor.
  std::vector<Point> warped(double tw, double th, double* blend, const StopToken* stop = nullptr) const;

 private:
  const double width_, height_;
  const PatchModel model_;
  const Mesh mesh_;
};

// The registry entry "patch": precompute builds the PatchModel (patch.<saliency>.bin).
const RetargetingMethod& patch_method();

}  // namespace zoomwarp::warp
