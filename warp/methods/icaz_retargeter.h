// ICAZ [ICAZ §5] and the traditional zoom it is compared with [ICAZ §1, §6.1], seen through the
// Retargeter interface every other method has, so that a route or a tool that shows views never
// asks which method it holds: view(), render(), and the geomorph pair of a zoom action — ICAZ's
// own common refinement of the two LOD cuts (Icaz::geomorph), traditional zoom's one coarsest
// mesh vertex by vertex (the interface's default).
//
// The adapter holds the image's shared Icaz operator (the forest and coarse-warp caches that make
// panning cheap belong to it, not to the adapter): it is made per request, costs nothing, and
// weighs nothing of its own — the operator is weighed where it is kept (api/warp_engines.h).
//
// Thread safety: as the Icaz operator, every member may be called from several threads at once.
#pragma once

#include <cstddef>
#include <memory>

#include "warp/icaz/icaz.h"
#include "warp/methods/retargeter.h"

namespace zoomwarp::warp {

class IcazRetargeter : public Retargeter {
 public:
  enum class Zoom {
    kContentAware,  // Icaz::view: the warp per view, relaxing as the viewing area shrinks
    kTraditional,   // Icaz::traditional: uniform scaling and cropping, letterboxed at z = 0
  };

  IcazRetargeter(std::shared_ptr<Icaz> icaz, Zoom zoom) : icaz_(std::move(icaz)), zoom_(zoom) {}

  View view(const ViewRequest& request) override;
  Geomorph geomorph(const ViewRequest& from, const ViewRequest& to, View* to_view = nullptr) override;
  // 0: the operator's bytes are counted where it is kept.
  std::size_t memory_bytes() override { return 0; }

 private:
  std::shared_ptr<Icaz> icaz_;
  Zoom zoom_;
};

}  // namespace zoomwarp::warp
