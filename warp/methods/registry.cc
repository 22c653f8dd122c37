// The list of registered methods: each method folder declares its description in its own header,
// and this file is the one place that names them all (no static-initialisation tricks).
#include "warp/methods/retargeting_method.h"

#include "warp/methods/mp/mp_retargeter.h"
#include "warp/methods/patch/patch_retargeter.h"
#include "warp/methods/polyfem/polyfem_retargeter.h"
#include "warp/methods/retarget_zoom/retarget_zoom.h"
#include "warp/methods/seam/seam_carving.h"

namespace zoomwarp::warp {

std::span<const RetargetingMethod* const> retargeting_methods() {
  static const RetargetingMethod* const kAll[] = {&retarget_zoom_method(), &seam_carving_method(), &mp_method(), &patch_method(), &polyfem_method()};
  return kAll;
}

const RetargetingMethod* find_retargeting_method(std::string_view name) {
  for (const RetargetingMethod* m : retargeting_methods())
    if (m->name == name) return m;
  return nullptr;
}

}  // namespace zoomwarp::warp
