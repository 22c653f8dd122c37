// What the server says about itself: the web viewer (web/) at "/" with its scripts and style
// sheet, the JSON index at /v1, the OpenAPI document, and /v1/methods.
#include <nlohmann/json.hpp>

#include "api/assets.h"
#include "api/errors.h"
#include "api/http_caching.h"
#include "api/responses.h"
#include "api/router.h"
#include "api/view_methods.h"

namespace zoomwarp::api {

using nlohmann::json;

// The web viewer (web/): its page at "/", its scripts and style sheet by file name. no-cache, so a
// browser revalidates them and picks up a new server's viewer at once.
namespace {
Response web_file(const std::string& name, const std::string& content_type) {
  const auto body = asset(name);
  if (!body) throw ApiError(404, "file_not_found", "the web viewer has no file " + name);
  Response r = body_response(content_type, std::string(*body));
  r.route = "web";
  r.set_header("Cache-Control", "no-cache");
  return r;
}
}  // namespace

std::optional<Response> Router::web_page(const Request&, const PathParams&, bool) {
  return web_file("index.html", "text/html; charset=utf-8");
}

std::optional<Response> Router::web_script(const Request&, const PathParams& p, bool) {
  return web_file(param(p, "file") + ".js", "text/javascript; charset=utf-8");
}

std::optional<Response> Router::web_style(const Request&, const PathParams& p, bool) {
  return web_file(param(p, "file") + ".css", "text/css; charset=utf-8");
}

// "/v1": where to go from here.
std::optional<Response> Router::index(const Request&, const PathParams&, bool) {
  Response r = json_response(200, {{"service", "zoomwarp"},
                                   {"links",
                                    {{"viewer", "/"},
                                     {"images", "/v1/images"},
                                     {"methods", "/v1/methods"},
                                     {"openapi", "/openapi.json"},
                                     {"dzi", "/dzi/{id}.dzi"},
                                     {"iiif", "/iiif/3/{id}/info.json"},
                                     {"manifest", "/iiif/presentation/3/{id}/manifest"},
                                     {"collection", "/iiif/presentation/3/collection"},
                                     {"health", "/healthz"},
                                     {"readiness", "/readyz"},
                                     {"metrics", "/metrics"}}}});
  r.route = "index";
  return r;
}

std::optional<Response> Router::openapi(const Request&, const PathParams&, bool) {
  Response r = body_response("application/json", std::string(*asset("openapi.json")));
  r.route = "openapi";
  r.set_header("Cache-Control", "no-cache");
  return r;
}

// The body of /v1/methods: api's own methods and the registered ones (view_query.h
// view_methods()) with what each does with lines, the saliency kinds and the line sets (the
// first is the default). It depends on the binary only, so it is made once and
// its ETag is its digest.
namespace {
const std::string& methods_body() {
  static const std::string body = [] {
    json methods = json::array();
    for (const ViewMethod& v : view_methods()) {
      const MethodDescription& m = v.description;
      methods.push_back({{"name", std::string(m.name)},
                         {"summary", std::string(m.summary)},
                         {"zoom", std::string(m.zoom)},
                         {"mesh", m.has_mesh},
                         {"lines", m.lines.empty() ? json(nullptr) : json(std::string(m.lines))}});
    }
    json saliency = json::array();
    for (const warp::Saliency s : warp::kSaliencies) saliency.push_back(std::string(warp::saliency_name(s)));
    json lines = json::array();
    for (const warp::LineSet s : warp::kLineSets) lines.push_back(std::string(warp::line_set_name(s)));
    return json{{"methods", methods}, {"saliency", saliency}, {"lines", lines}}.dump(2) + "\n";
  }();
  return body;
}
}  // namespace

std::optional<Response> Router::list_methods(const Request& req, const PathParams&, bool) {
  const std::string& body = methods_body();
  const std::string etag = make_etag("methods", body);
  Response r;
  if (!req.if_none_match.empty() && if_none_match_matches(req.if_none_match, etag)) r.status = 304;
  else r = body_response("application/json", body);
  r.route = "methods";
  r.set_header("ETag", etag);
  r.set_header("Cache-Control", "public, max-age=" + std::to_string(config_.cache_max_age));
  return r;
}

}  // namespace zoomwarp::api
