#include "warp/methods/icaz_retargeter.h"

namespace zoomwarp::warp {

View IcazRetargeter::view(const ViewRequest& request) {
  return zoom_ == Zoom::kContentAware ? icaz_->view(request) : icaz_->traditional(request);
}

// ICAZ's two views have LOD cuts of their own: the pair is their common refinement, made in one
// forest epoch. Traditional zoom draws one coarsest mesh in every view: the default pairs it
// vertex by vertex.
Geomorph IcazRetargeter::geomorph(const ViewRequest& from, const ViewRequest& to, View* to_view) {
  if (zoom_ == Zoom::kContentAware) return icaz_->geomorph(from, to, to_view);
  return Retargeter::geomorph(from, to, to_view);
}

}  // namespace zoomwarp::warp
