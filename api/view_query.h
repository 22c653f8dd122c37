// The common view parameters of /viewport and /mesh (api/openapi.json, "ViewParameters"):
//
//   zoom     0…1, default 0            cx, cy  view centre in full-resolution image pixels,
//   w, h     screen pixels, 16…4096             0…width / 0…height, default the image centre
//   method   icaz (default) | traditional | a registered retargeting method
//            (api/view_methods.h: retarget-zoom, seam, …)
//   saliency default (default) | gbvs    which saliency map drives a content-aware method
//   lines    auto (default) | curator | none   which lines a method keeps straight
//            (warp/analysis/line_set.h); ignored (taken as curator) by a method that takes none
//   curve    geometric (default) | linear
//   fit      auto (default) | warp | crop | pad   what zoom 0 does where the image's aspect is not
//            the screen's (warp/window/fit.h); max_distortion 1…8, default 1.4: auto's budget
//   from_zoom, from_cx, from_cy   (mesh only) the previous view, for the geomorph pair
//   format   jpg (default) | png | webp,  quality 1…100   (viewport only)
//   expires, sig   a signed URL's (api/url_signing.h): accepted once each, checked by the router,
//                  not part of canonical()
//
// Parsing is strict: a missing w or h, a number that is not a plain finite decimal, a value out
// of range, an unknown or repeated parameter is a 400 (ApiError), never a guess.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "api/view_methods.h"
#include "tiles/image_format.h"
#include "warp/analysis/line_set.h"
#include "warp/core/view.h"
#include "warp/window/fit.h"

namespace zoomwarp::api {

struct ViewQuery {
  warp::ViewRequest view;
  const ViewMethod* method = &default_view_method();  // never null
  warp::Saliency saliency = warp::Saliency::kDefault;
  warp::LineSet lines = warp::LineSet::kAuto;
  warp::FitOptions fit;  // framed by warp/window before a method draws (api/framed_views.h)
  std::optional<warp::ViewRequest> from;  // from_* given (all three optional, default: this view's)
  tiles::ImageFormat format = tiles::ImageFormat::kJpeg;
  int quality = 0;  // 0: the server's default

  // A canonical form of everything that determines the answer, for cache keys and ETags.
  std::string canonical() const;

  // The `method=` value: "icaz", "traditional", "retarget-zoom", "seam", …
  std::string_view method_name() const;
};

enum class ViewRoute { kViewport, kMesh };

// Throws ApiError(400) for anything malformed or out of range.
ViewQuery parse_view_query(std::string_view raw_query, ViewRoute route, double image_width, double image_height);


}  // namespace zoomwarp::api
