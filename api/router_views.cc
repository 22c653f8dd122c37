// The warp engine's routes: /v1/images/{id}/viewport, /mesh, /significance.png, /lines (GET and
// PUT) and /significance (PATCH). Views are pure functions of (image version, canonical view
// parameters), so they share the router's ETags, response cache and single flight; edits publish
// a new image version, which changes every ETag of the image at once.
#include <cmath>
#include <nlohmann/json.hpp>

#include "api/errors.h"
#include "api/http_caching.h"
#include "api/mesh_json.h"
#include "api/responses.h"
#include "api/router.h"
#include "warp/image_analysis.h"
#include "warp/render.h"

namespace zoomwarp::api {

namespace {

using nlohmann::json;

warp::View view_by(warp::Icaz& engine, ViewMethod method, const warp::ViewRequest& r) {
  switch (method) {
    case ViewMethod::kTraditional: return engine.traditional(r);
    case ViewMethod::kRetargetZoom: return engine.retarget_zoom(r);
    case ViewMethod::kIcaz: break;
  }
  return engine.view(r);
}

json lines_json(const std::vector<warp::Segment>& lines) {
  json out = json::array();
  for (const auto& l : lines) out.push_back({l.a.x, l.a.y, l.b.x, l.b.y});
  return out;
}

[[noreturn]] void bad_body(const std::string& message) { throw ApiError(400, "invalid_body", message); }

// A finite number inside [lo, hi] from a JSON value.
double coordinate(const json& j, double lo, double hi, const char* what) {
  if (!j.is_number()) bad_body(std::string(what) + " must be numbers");
  const double v = j.get<double>();
  if (!std::isfinite(v) || v < lo || v > hi) bad_body(what + std::string(" must lie inside the image"));
  return v;
}

warp::ModelEdit lines_edit(const json& body, double W, double H) {
  if (!body.is_object() || !body.contains("lines") || !body["lines"].is_array() || body.size() != 1)
    bad_body(R"(expected {"lines": [[x0, y0, x1, y1], …]})");
  std::vector<warp::Segment> lines;
  for (const json& l : body["lines"]) {
    if (!l.is_array() || l.size() != 4) bad_body("each line is [x0, y0, x1, y1]");
    lines.push_back({{coordinate(l[0], 0, W, "line ends"), coordinate(l[1], 0, H, "line ends")},
                     {coordinate(l[2], 0, W, "line ends"), coordinate(l[3], 0, H, "line ends")}});
  }
  warp::ModelEdit edit;
  edit.lines = std::move(lines);
  return edit;
}

warp::ModelEdit significance_edit(const json& body, double W, double H) {
  if (!body.is_object() || !body.contains("regions") || !body["regions"].is_array() || body.size() != 1 ||
      body["regions"].empty())
    bad_body(R"(expected {"regions": [{"rect": [x, y, w, h], "weight": s} or {"polygon": [[x, y], …], "weight": s}, …]})");
  warp::ModelEdit edit;
  for (const json& r : body["regions"]) {
    if (!r.is_object() || !r.contains("weight") || r.size() != 2 || (!r.contains("rect") && !r.contains("polygon")))
      bad_body("each region has a weight and either a rect or a polygon");
    if (!r["weight"].is_number()) bad_body("weight must be a number in [0, 1]");
    const double weight = r["weight"].get<double>();
    if (!(weight >= 0 && weight <= 1)) bad_body("weight must be in [0, 1]");
    warp::SignificanceEdit e;
    e.weight = float(weight);
    if (r.contains("rect")) {
      const json& rect = r["rect"];
      if (!rect.is_array() || rect.size() != 4) bad_body("rect is [x, y, w, h]");
      const double x = coordinate(rect[0], 0, W, "rect"), y = coordinate(rect[1], 0, H, "rect");
      const double w = coordinate(rect[2], 0, W - x, "rect"), h = coordinate(rect[3], 0, H - y, "rect");
      if (!(w > 0 && h > 0)) bad_body("rect needs a positive width and height");
      e.polygon = {{x, y}, {x + w, y}, {x + w, y + h}, {x, y + h}};
    } else {
      const json& polygon = r["polygon"];
      if (!polygon.is_array() || polygon.size() < 3) bad_body("a polygon needs at least 3 points");
      for (const json& p : polygon) {
        if (!p.is_array() || p.size() != 2) bad_body("polygon points are [x, y]");
        e.polygon.push_back({coordinate(p[0], 0, W, "polygon points"), coordinate(p[1], 0, H, "polygon points")});
      }
    }
    edit.significance.push_back(std::move(e));
  }
  return edit;
}

// The route's last path segment says which: viewport, mesh, significance.png or lines.
std::string_view last_segment(const std::string& path) { return std::string_view(path).substr(path.rfind('/') + 1); }

}  // namespace

std::optional<Response> Router::view_route(const Request& req, const PathParams& p, bool may_compute) {
  auto entry = find_image(store_, param(p, "id"));
  const std::string what(last_segment(req.path));
  if (what == "significance.png") {
    return image_response(req, *entry, "significance_png", "", may_compute, [&](const tiles::ImageEntry& e) {
      const warp::SignificanceMap map = engines_.get(e)->model().significance;
      tiles::Raster grey(map.width, map.height, 1);
      for (std::size_t i = 0; i < map.values.size(); ++i) grey.pixels[i] = std::uint8_t(std::lround(map.values[i] * 255));
      return body_response("image/png", tiles::encode_image(grey, tiles::ImageFormat::kPng, config_.encode));
    });
  }
  if (what == "lines") {
    return image_response(req, *entry, "lines_get", "", true, [&](const tiles::ImageEntry& e) {
      return body_response("application/json", json{{"lines", lines_json(engines_.get(e)->model().lines)}}.dump() + "\n");
    });
  }
  const ViewRoute route = what == "mesh" ? ViewRoute::kMesh : ViewRoute::kViewport;
  const ViewQuery q = parse_view_query(req.query, route, entry->manifest.width, entry->manifest.height);
  return image_response(req, *entry, what, q.canonical(), may_compute, [&](const tiles::ImageEntry& e) {
    auto engine = engines_.get(e);
    try {
      if (route == ViewRoute::kViewport) {
        const warp::View v = view_by(*engine, q.method, q.view);
        const tiles::Raster screen = warp::render_view(v, q.view.screen_width, q.view.screen_height, e, reader_);
        tiles::EncodeOptions encode = config_.encode;
        if (q.quality > 0) encode.jpeg_quality = encode.webp_quality = q.quality;
        return body_response(std::string(tiles::mime_type(q.format)), tiles::encode_image(screen, q.format, encode));
      }
      const std::string tile_ext = e.manifest.has_alpha() ? "png" : "jpg";
      if (!q.from) return body_response("application/json", mesh_json(e.manifest, q, view_by(*engine, q.method, q.view), nullptr, config_.dzi, tile_ext));
      if (q.method == ViewMethod::kIcaz) {
        warp::View to;
        const warp::Geomorph morph = engine->geomorph(*q.from, q.view, &to);
        return body_response("application/json", mesh_json(e.manifest, q, to, &morph, config_.dzi, tile_ext));
      }
      // The baselines draw the same (coarsest) mesh in every view: the pair is vertex by vertex.
      const warp::View to = view_by(*engine, q.method, q.view), from = view_by(*engine, q.method, *q.from);
      const warp::Geomorph morph{to.source, {}, from.screen, to.screen};
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
  if (!req.if_match.empty() && !etag_matches(req.if_match, image_etag))
    throw ApiError(412, "precondition_failed", "the image changed: its ETag is now " + image_etag);
  json body;
  try {
    body = json::parse(req.body);
  } catch (const json::exception&) {
    bad_body("the body is not valid JSON");
  }
  const double W = entry->manifest.width, H = entry->manifest.height;
  const warp::ModelEdit edit = what == "lines" ? lines_edit(body, W, H) : significance_edit(body, W, H);
  try {
    warp::edit_image_model(store_, *entry, edit, engines_.get(*entry)->model());
  } catch (const std::invalid_argument& err) {
    bad_body(err.what());
  } catch (const tiles::VersionConflict& err) {
    throw ApiError(409, "conflict", std::string(err.what()) + "; read the image again and retry");
  }
  Response r = describe(id);
  r.route = what == "lines" ? "lines_put" : "significance_patch";
  return r;
}

}  // namespace zoomwarp::api
