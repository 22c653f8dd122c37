#include "api/framed_views.h"

#include "warp/window/view_window.h"

namespace zoomwarp::api {

FramedQuery ViewFraming::frame(const tiles::ImageEntry& image, const ViewQuery& q, const warp::StopToken* stop,
                               bool for_screen) {
  const bool warps = warp::fit_warps(q.fit.fit);
  const ViewMethod& method = warps ? *q.method : *find_view_method("traditional");
  const bool method_warps = method.registered || method.icaz_zoom != warp::IcazRetargeter::Zoom::kTraditional;
  const warp::Saliency saliency = q.method->reads_saliency ? q.saliency : warp::Saliency::kDefault;
  // The frame first: the method's warp for it starts (in the background) before anything else.
  warp::WindowFrame wf = warp::window_frame(image.manifest.width, image.manifest.height, q.fit, q.view.screen_width,
                                            q.view.screen_height, method_warps);
  FramedQuery out;
  out.engine = for_screen ? engines_.view_engine(image, method, saliency, q.lines, stop, q.view.screen_width,
                                                 q.view.screen_height, wf.frame)
                          : engines_.view_engine(image, method, saliency, q.lines, stop);
  out.view = q.view, out.from = q.from;
  if (!wf.window.crops) {
    out.view.frame = wf.frame;
    if (out.from) out.from->frame = wf.frame;
    return out;
  }
  // The window's offset, once per key (see the header): placed by the map of the ICAZ engine the
  // view is drawn from (icaz, traditional), or, for a registered method, of the version's model
  // every method reads (the default kind, the curator's regions and faces in it) — loaded already,
  // whatever saliency= the method warps by — then, for a warp, chosen again through it.
  std::string key = image.manifest.id + "@" + image.manifest.version + "|" + std::string(method.name()) + "|" +
                    std::string(warp::saliency_name(saliency)) + "|" + std::string(warp::line_set_name(q.lines)) + "|" +
                    std::to_string(q.view.screen_width) + "x" + std::to_string(q.view.screen_height) + "|" +
                    std::string(warp::fit_name(q.fit.fit)) + "," + std::to_string(q.fit.max_distortion) + "|" +
                    (q.view.curve == warp::ZoomCurve::kLinear ? "linear" : "geometric");
  std::optional<double> kept;
  {
    std::lock_guard lock(mu_);
    if (const double* found = offsets_.find(key)) kept = *found;
  }
  const double W = image.manifest.width, H = image.manifest.height;
  double offset = 0;
  if (kept) {
    offset = *kept;
  } else {
    const warp::SignificanceProfile& profile =
        (method.registered ? engines_.get(image, warp::Saliency::kDefault, warp::LineSet::kCurator, stop)
                           : engines_.get(image, saliency, q.lines, stop))
            ->significance_profile();
    warp::place_window(wf.window, profile);
    offset = warp::window_offset(wf.window, profile);
    if (method_warps && out.engine->has_mesh()) {
      warp::ViewRequest zoom0 = q.view;
      zoom0.zoom = 0, zoom0.cx = W / 2, zoom0.cy = H / 2, zoom0.stop = stop;
      offset = warp::warped_window_offset(out.engine->view(warp::panned_view(zoom0, wf, offset, W, H)), wf.window, profile);
    }
    std::lock_guard lock(mu_);
    offsets_.put(std::move(key), offset);
  }
  out.view = warp::panned_view(q.view, wf, offset, W, H);
  if (q.from) out.from = warp::panned_view(*q.from, wf, offset, W, H);
  return out;
}

}  // namespace zoomwarp::api
