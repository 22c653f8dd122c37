// A view query as it is drawn (issue 41): `fit=` applied once, before any method sees the request,
// so that no route, tool or method frames views its own way. The engine is the query's method's —
// or traditional zoom's for a fit that does not warp (crop, pad): a warp to the image's own aspect
// is no warp — and the request (and a geomorph's from-view) is framed by warp/window/view_window.h:
// the frame from the sizes alone, so the method's warp for it is started first; where it crops,
// the window from the significance of the ICAZ engine the view is drawn from (icaz, traditional)
// or of the version's model that every registered method's engine reads (the default kind with
// the curator's regions and faces): no engine is loaded for framing alone.
//
// Where a view crops (fit=auto beyond its budget, fit=crop), its frame and window are placed once
// per version, method, saliency, lines, screen and fit: for fit=auto the frame is fitted to the
// method's own warp (view_window.h budgeted_frame: up to four views at zoom 0, measured against
// the map the window is placed by), and for a warp the window is centred as the method draws it
// — the warp enlarges what matters, so the source window's centre is not the middle of the
// warped window (warped_window_offset). What is placed is kept here (a few thousand, the least
// recently used dropped), so after the first a view costs what it cost before: no placement, no
// profile read and no measuring on the request path.
//
// Thread safety: every member may be called from several threads at once.
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "api/view_query.h"
#include "api/warp_engines.h"
#include "warp/methods/recent_cache.h"
#include "warp/window/view_window.h"

namespace zoomwarp::api {

struct FramedQuery {
  std::shared_ptr<warp::Retargeter> engine;
  warp::ViewRequest view;
  std::optional<warp::ViewRequest> from;
};

class ViewFraming {
 public:
  explicit ViewFraming(WarpEngines& engines) : engines_(engines) {}

  // Throws as WarpEngines::view_engine does. `for_screen`: the engine's warp for the query's
  // screen made first, in the background (the routes); false: the engine as loaded (compare).
  FramedQuery frame(const tiles::ImageEntry& image, const ViewQuery& query, const warp::StopToken* stop,
                    bool for_screen = true);

 private:
  static constexpr std::size_t kKeptPlacements = 4096;

  // A cropping view's frame and its window's offset from the image centre (view_window.h).
  struct Placed {
    warp::WindowFrame frame;
    double offset = 0;
  };
  Placed place(const tiles::ImageEntry& image, const ViewQuery& query, const ViewMethod& method, bool method_warps,
               warp::Retargeter& engine, warp::Saliency saliency, const warp::StopToken* stop);

  WarpEngines& engines_;
  std::mutex mu_;
  warp::RecentCache<std::string, Placed> placed_{kKeptPlacements};  // guarded by mu_
};

}  // namespace zoomwarp::api
