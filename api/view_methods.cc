#include "api/view_methods.h"

namespace zoomwarp::api {

namespace {

using Zoom = warp::IcazRetargeter::Zoom;

std::vector<ViewMethod> make_view_methods() {
  std::vector<ViewMethod> out = {
      {{"icaz",
        "Interactive Content-Aware Zooming: a warp per view that keeps the important regions large and "
        "undistorted, and gives up the distortion as you zoom in.",
        "0: the whole image warped to the screen's aspect ratio; 1: 100 % (one screen pixel per image pixel), "
        "undistorted; in between, the warp relaxes as the viewing area shrinks.",
        true,
        "the line set's lines are edges of the coarsest mesh and keep their normal through the warp ([ICAZ §4.3]'s "
        "line term); detected lines are cut back where they cross and left out where the mesh cannot take them"},
       nullptr,
       Zoom::kContentAware,
       true},
      {{"traditional", "Uniform scaling and cropping: the image's own aspect ratio, letterboxed when zoomed out.",
        "0: the whole image fits the screen; 1: 100 % (one screen pixel per image pixel).", true, ""},
       nullptr,
       Zoom::kTraditional,
       false},
  };
  const std::size_t own = out.size();
  for (const warp::RetargetingMethod* m : warp::retargeting_methods()) {
    bool shadowed = false;
    for (std::size_t i = 0; i < own; ++i) shadowed |= out[i].name() == m->name;
    if (!shadowed) out.push_back({{m->name, m->summary, m->zoom, m->has_mesh, m->lines}, m});
  }
  return out;
}

}  // namespace

const std::vector<ViewMethod>& view_methods() {
  static const std::vector<ViewMethod> table = make_view_methods();
  return table;
}

const ViewMethod* find_view_method(std::string_view name) {
  for (const ViewMethod& m : view_methods())
    if (m.name() == name) return &m;
  return nullptr;
}

const ViewMethod& default_view_method() { return view_methods().front(); }

}  // namespace zoomwarp::api
