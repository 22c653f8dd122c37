#include "api/framed_views.h"

#include "warp/compare/metrics.h"
#include "warp/window/view_window.h"

namespace zoomwarp::api {

FramedQuery ViewFraming::frame(const tiles::ImageEntry& image, const ViewQuery& q, const warp::StopToken* stop,
                               bool for_screen) {
  const bool warps = warp::fit_warps(q.fit.fit);
  const ViewMethod& method = warps ? *q.method : *find_view_method("traditional");
  const bool method_warps = method.registered || method.icaz_zoom != warp::IcazRetargeter::Zoom::kTraditional;
  const warp::Saliency saliency = q.method->reads_saliency ? q.saliency : warp::Saliency::kDefault;
  const double W = image.manifest.width, H = image.manifest.height;
  const int sw = q.view.screen_width, sh = q.view.screen_height;
  // The frame from the sizes alone, or as placed before for this key (see the header).
  warp::WindowFrame wf = warp::window_frame(W, H, q.fit, sw, sh, method_warps);
  // fit=auto measures the method's warp even where the sizes alone crop nothing (budgeted_frame).
  const bool placed = wf.window.crops || (q.fit.fit == warp::Fit::kAuto && method_warps && W * sh != H * sw);
  std::string key;
  std::optional<Placed> kept;
  if (placed) {
    key = image.manifest.id + "@" + image.manifest.version + "|" + std::string(method.name()) + "|" +
          std::string(warp::saliency_name(saliency)) + "|" + std::string(warp::line_set_name(q.lines)) + "|" +
          std::to_string(sw) + "x" + std::to_string(sh) + "|" + std::string(warp::fit_name(q.fit.fit)) + "," +
          std::to_string(q.fit.max_distortion) + "|" + (q.view.curve == warp::ZoomCurve::kLinear ? "linear" : "geometric");
    std::lock_guard lock(mu_);
    if (const Placed* found = placed_.find(key)) kept = *found;
  }
  if (kept) wf = kept->frame;
  // The method's warp for the frame starts (in the background) before anything else.
  FramedQuery out;
  out.engine = for_screen ? engines_.view_engine(image, method, saliency, q.lines, stop, sw, sh, wf.frame)
                          : engines_.view_engine(image, method, saliency, q.lines, stop);
  out.view = q.view, out.from = q.from;
  if (!placed) {
    out.view.frame = wf.frame;
    if (out.from) out.from->frame = wf.frame;
    return out;
  }
  if (!kept) {
    kept = place(image, q, method, method_warps, *out.engine, saliency, stop);
    std::lock_guard lock(mu_);
    placed_.put(std::move(key), *kept);
  }
  wf = kept->frame;
  out.view = warp::panned_view(q.view, wf, kept->offset, W, H);
  if (q.from) out.from = warp::panned_view(*q.from, wf, kept->offset, W, H);
  return out;
}

// A cropping frame's window, once per key: placed by the map of the ICAZ engine the view is drawn
// from (icaz, traditional), or, for a registered method, of the version's model every method
// reads (the default kind, the curator's regions and faces in it) — loaded already, whatever
// saliency= the method warps by. For fit=auto the frame is fitted to the method's own warp by
// that map (budgeted_frame), and for a warp the offset is chosen again through its view at zoom 0.
ViewFraming::Placed ViewFraming::place(const tiles::ImageEntry& image, const ViewQuery& q, const ViewMethod& method,
                                       bool method_warps, warp::Retargeter& engine, warp::Saliency saliency,
                                       const warp::StopToken* stop) {
  const double W = image.manifest.width, H = image.manifest.height;
  const int sw = q.view.screen_width, sh = q.view.screen_height;
  const std::shared_ptr<warp::Icaz> reference =
      method.registered ? engines_.get(image, warp::Saliency::kDefault, warp::LineSet::kCurator, stop)
                        : engines_.get(image, saliency, q.lines, stop);
  const warp::SignificanceProfile& profile = reference->significance_profile();
  const bool measured = method_warps && engine.has_mesh();
  // The method's view at zoom 0, centred on a frame's placed window (the last one drawn kept: the
  // chosen frame is usually the last measured, and its view places the offset below).
  struct Drawn {
    warp::WindowFrame frame;
    double offset = 0;
    std::optional<warp::View> view;
  } last;
  const auto draw = [&](const warp::WindowFrame& f) {
    Drawn d{f, 0, std::nullopt};
    warp::place_window(d.frame.window, profile);
    d.offset = warp::window_offset(d.frame.window, profile);
    if (measured) {
      warp::ViewRequest zoom0 = q.view;
      zoom0.zoom = 0, zoom0.cx = W / 2, zoom0.cy = H / 2, zoom0.stop = stop, zoom0.frame = {};
      d.view = engine.view(warp::panned_view(zoom0, d.frame, d.offset, W, H));
    }
    return d;
  };
  warp::WindowFrame frame = warp::window_frame(W, H, q.fit, sw, sh, method_warps);
  if (measured && q.fit.fit == warp::Fit::kAuto)
    frame = warp::budgeted_frame(W, H, q.fit, sw, sh, [&](const warp::WindowFrame& f) {
      last = draw(f);
      const warp::SquashMeasures m = warp::squash_measures(*last.view, reference->model().significance, sw, sh);
      return warp::SalientSqueezeMeasure{m.anisotropy_p90.value_or(1), m.anisotropy_p99.value_or(1)};
    });
  if (!(last.frame.frame.aspect == frame.frame.aspect && last.frame.window.length == frame.window.length)) last = draw(frame);
  Placed out{last.frame, last.offset};
  if (last.view && out.frame.window.crops)
    out.offset = warp::warped_window_offset(*last.view, out.frame.window, profile);
  return out;
}

}  // namespace zoomwarp::api
