// Every `method=` value a view request may name, as one table: api's own two — ICAZ and the
// traditional zoom it is compared with [ICAZ §1, §6.1], both drawn by the ICAZ operator — then
// each registered retargeting method (warp::retargeting_methods()). It is what GET /v1/methods
// lists, what parse_view_query() resolves `method=` to, what `zoomwarp replay --method` and
// `zoomwarp compare --methods` accept, and what the warp engines make a Retargeter of
// (api/warp_engines.h; api's own through warp/methods/icaz_retargeter.h): no route and no tool
// branches on a method's name.
//
// Thread safety: an immutable table, built on first use.
#pragma once

#include <string_view>
#include <vector>

#include "warp/methods/icaz_retargeter.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::api {

// A method as GET /v1/methods describes it to clients (the viewer's method menus).
struct MethodDescription {
  std::string_view name;
  std::string_view summary;  // one sentence
  std::string_view zoom;     // what `zoom` means for it
  bool has_mesh = true;      // false: /mesh answers 501, a client shows /viewport images
  std::string_view lines;    // what it does with `lines=` (warp/analysis/line_set.h); empty: takes none
};

struct ViewMethod {
  MethodDescription description;
  // The registered method; null for api's own, which `icaz_zoom` then tells apart.
  const warp::RetargetingMethod* registered = nullptr;
  warp::IcazRetargeter::Zoom icaz_zoom = warp::IcazRetargeter::Zoom::kContentAware;
  // Whether `saliency=` changes its views (traditional zoom reads no map).
  bool reads_saliency = true;

  std::string_view name() const { return description.name; }
  // Whether `lines=` changes its views: a method that takes no lines shows the same view for
  // every line set (one cache entry, one engine).
  bool takes_lines() const { return !description.lines.empty(); }
};

// In the order a viewer lists them: icaz (the default), traditional, then the registered ones. A
// registered method named like one of api's own is left out: the name means api's own.
const std::vector<ViewMethod>& view_methods();

// The method called `name`, or null.
const ViewMethod* find_view_method(std::string_view name);

// method=icaz, what a view without `method=` shows.
const ViewMethod& default_view_method();

}  // namespace zoomwarp::api
