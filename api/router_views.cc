// The warp engine's routes: /v1/images/{id}/viewport, /mesh, /significance.png, /lines (GET and
// PUT) and /significance (PATCH). Views are pure functions of (image version, canonical view
// parameters), so they share the router's ETags, response cache and single flight; edits publish
// a new image version, which changes every ETag of the image at once.
#include <cmath>
#include <optional>
#include <nlohmann/json.hpp>

#include "api/edit_body.h"
#include "api/errors.h"
#include "api/framed_views.h"
#include "api/http_caching.h"
#include "api/mesh_json.h"
#include "api/responses.h"
#include "api/url.h"
#include "api/router.h"
#include "api/view_query.h"
#include "warp/analysis/detected_lines.h"
#include "warp/analysis/image_analysis.h"

namespace zoomwarp::api {

namespace {

using nlohmann::json;

json lines_json(const std::vector<warp::Segment>& lines) {
  json out = json::array();
  for (const auto& l : lines) out.push_back({l.a.x, l.a.y, l.b.x, l.b.y});
  return out;
}

// The route's last path segment says which: viewport, mesh, significance.png or lines.
std::string_view last_segment(const std::string& path) { return std::string_view(path).substr(path.rfind('/') + 1); }

// GET lines takes no parameters but a signed URL's; like /mesh, it refuses what it does not know.
void reject_query(const Request& req, std::string_view route) {
  const auto pairs = parse_query(req.query);
  if (!pairs) throw ApiError(400, "bad_request", "malformed query string");
  for (const auto& [name, value] : *pairs)
    if (!is_signature_parameter(name))
      throw ApiError(400, "bad_request", std::string(route) + " takes no query parameters but expires and sig, not '" + name + "'");
}

// significance.png takes saliency=default|gbvs (which map) and a signed URL's parameters (the
// router has refused a parameter given twice).
warp::Saliency significance_query(const Request& req) {
  const auto pairs = parse_query(req.query);
  if (!pairs) throw ApiError(400, "bad_request", "malformed query string");
  warp::Saliency kind = warp::Saliency::kDefault;
  for (const auto& [name, value] : *pairs) {
    if (is_signature_parameter(name)) continue;
    if (name != "saliency")
      throw ApiError(400, "bad_request",
                     "significance.png takes no query parameters but saliency, expires and sig, not '" + name + "'");
    const auto parsed = warp::parse_saliency(value);
    if (!parsed) throw ApiError(400, "bad_request", "saliency must be default or gbvs, not '" + value + "'");
    kind = *parsed;
  }
  return kind;
}

}  // namespace

std::optional<Response> Router::view_route(const Request& req, const PathParams& p, bool may_compute) {
  auto entry = access_.readable_image(req, param(p, "id"));
  const std::string what(last_segment(req.path));
  if (what == "significance.png") {
    const warp::Saliency kind = significance_query(req);
    // The default map keeps the ETag it had before there was a choice.
    const std::string variant = kind == warp::Saliency::kDefault ? "" : std::string(warp::saliency_name(kind));
    return responses_.image_response(req, *entry, "significance_png", variant, may_compute, [&](const tiles::ImageEntry& e) {
      // The map the ICAZ engine of that kind warps with: faces and the curator's edits painted in.
      const std::shared_ptr<warp::Icaz> engine = engines_.get(e, kind, warp::LineSet::kCurator, req.stop);
      const warp::SignificanceMap& map = engine->model().significance;
      tiles::Raster grey(map.width, map.height, 1);
      for (std::size_t i = 0; i < map.values.size(); ++i) grey.pixels[i] = std::uint8_t(std::lround(map.values[i] * 255));
      return body_response("image/png", tiles::encode_image(grey, tiles::ImageFormat::kPng, config_.encode));
    });
  }
  if (what == "lines") {
    reject_query(req, what);
    return responses_.image_response(req, *entry, "lines_get", "", may_compute, [&](const tiles::ImageEntry& e) {
      const warp::ImageModel& model = engines_.get(e, warp::Saliency::kDefault, warp::LineSet::kCurator, req.stop)->model();
      return body_response("application/json", json{{"lines", lines_json(model.lines)},
                                                    {"suggested", lines_json(warp::suggested_lines(e, reader_, model))},
                                                    {"dismissed", lines_json(model.dismissed_lines)}}
                                                       .dump() +
                                                   "\n");
    });
  }
  const ViewRoute route = what == "mesh" ? ViewRoute::kMesh : ViewRoute::kViewport;
  ViewQuery q = parse_view_query(req.query, route, entry->manifest.width, entry->manifest.height);
  q.view.stop = req.stop;  // both ends of a geomorph: the from-view is as much work as the view
  if (q.from) q.from->stop = req.stop;
  return responses_.image_response(req, *entry, what, q.canonical(), may_compute, [&](const tiles::ImageEntry& e) {
    try {
      // Whatever the method, it draws through a Retargeter (api/view_methods.h), its warp for this
      // screen made first (in the background: every view of that screen shares it), the request
      // framed for fit= first (api/framed_views.h).
      const FramedQuery framed = framing_.frame(e, q, req.stop);
      const std::shared_ptr<warp::Retargeter>& engine = framed.engine;
      if (route == ViewRoute::kViewport) {
        const tiles::Raster screen = engine->render(framed.view, e, reader_);
        warp::check_stop(req.stop);  // not worth encoding a view nobody waits for any more
        tiles::EncodeOptions encode = config_.encode;
        if (q.quality > 0) encode.jpeg_quality = encode.webp_quality = encode.avif_quality = encode.jxl_quality = q.quality;
        return body_response(std::string(tiles::mime_type(q.format)), tiles::encode_image(screen, q.format, encode));
      }
      if (!engine->has_mesh())
        throw ApiError(501, "not_implemented",
                       "method=" + std::string(q.method_name()) + " carves pixels away and has no mesh; use /viewport?method=" +
                           std::string(q.method_name()));
      const std::string tile_ext = e.manifest.has_alpha() ? "png" : "jpg";
      if (!framed.from)
        return body_response("application/json", mesh_json(e.manifest, q, engine->view(framed.view), nullptr, config_.dzi, tile_ext));
      warp::View to;
      const warp::Geomorph morph = engine->geomorph(*framed.from, framed.view, &to);
      return body_response("application/json", mesh_json(e.manifest, q, to, &morph, config_.dzi, tile_ext));
    } catch (const std::invalid_argument& err) {
      throw ApiError(400, "invalid_view", err.what());
    }
  });
}

std::optional<Response> Router::edit_route(const Request& req, const PathParams& p, bool may_compute) {
  if (!may_compute) return std::nullopt;
  const std::string& id = param(p, "id");
  const std::string what(last_segment(req.path));
  auto entry = find_image(store_, id);
  const std::string image_etag = make_etag(entry->manifest.version, "image");
  if (!req.if_match.empty() && !if_match_matches(req.if_match, image_etag))
    throw ApiError(412, "precondition_failed", "the image changed: its ETag is now " + image_etag);
  const std::string route = what == "lines" ? "lines_put" : "significance_patch";
  try {
    warp::check_stop(req.stop);
  } catch (const warp::Stopped& stopped) {
    // Out of time or cancelled while queued: not applied, so the client's retry is not a second edit.
    Response r = stopped_response(stopped.reason());
    r.route = route;
    return r;
  }
  const double W = entry->manifest.width, H = entry->manifest.height;
  const warp::ModelEdit edit = what == "lines" ? parse_lines_body(req.body, W, H) : parse_significance_body(req.body, W, H);
  try {
    warp::edit_image_model(store_, *entry, edit, engines_.get(*entry, warp::Saliency::kDefault, warp::LineSet::kCurator, req.stop)->model());
  } catch (const warp::LimitExceeded& err) {
    throw ApiError(413, err.limit(), err.what());
  } catch (const std::invalid_argument& err) {
    throw ApiError(400, "invalid_body", err.what());
  } catch (const tiles::VersionConflict& err) {
    throw ApiError(409, "conflict", std::string(err.what()) + "; read the image again and retry");
  }
  Response r = describe(*find_image(store_, id));
  r.route = route;
  return r;
}

}  // namespace zoomwarp::api
