#include "api/router.h"

#include <cctype>
#include <chrono>
#include <set>

#include "api/errors.h"
#include "api/url.h"
#include "tiles/store_deadline.h"
#include "tiles/store_errors.h"

namespace zoomwarp::api {

namespace {

Response method_not_allowed(const std::string& allow) {
  Response r = error_response(405, "method_not_allowed", "allowed methods: " + allow);
  r.set_header("Allow", allow);
  return r;
}

// A parameter given twice is ambiguous on every route, also on those that ignore their query
// string: which one a cache or proxy in front of us would key on is anyone's guess.
void reject_repeated_parameters(std::string_view query) {
  const auto pairs = parse_query(query);
  if (!pairs) return;  // malformed: the routes that read a query say so, the others ignore it
  std::set<std::string_view> seen;
  for (const auto& [name, value] : *pairs)
    if (!seen.insert(name).second) throw ApiError(400, "invalid_query", "parameter '" + name + "' is given twice");
}

bool host_is_sane(std::string_view h) {
  if (h.empty() || h.size() > 255) return false;
  for (char c : h)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == ':' || c == '[' || c == ']'))
      return false;
  return true;
}

}  // namespace

Router::Router(tiles::Store& store, tiles::PyramidReader& reader, RouterConfig config)
    : store_(store),
      reader_(reader),
      config_(std::move(config)),
      access_(store_, config_.access, config_.url_signer),
      responses_({.cache_bytes = config_.response_cache_bytes,
                  .failure_window = config_.failure_cache_window,
                  .cache_max_age = config_.cache_max_age,
                  .compute_hook = config_.compute_hook}),
      engines_(reader,
               {.budget_bytes = config_.warp_cache_bytes,
                .significance = config_.significance,
                .analysis_threads = config_.analysis_threads},
               config_.log) {}

bool Router::is_upload(std::string_view method, std::string_view path) {
  return method == "POST" && (path == "/v1/images" || path == "/v1/images/");
}

std::optional<Response> Router::try_answer_now(const Request& req) {
  // On the I/O thread the store is never waited for: with a deadline already past, what is not
  // in memory (a pointer to read again, a manifest of a bucket's) fails at once with
  // StoreUnavailable, and the request goes to a worker (dispatch).
  const tiles::StoreDeadlineScope no_store_requests(std::chrono::steady_clock::time_point::min());
  return dispatch(req, false);
}

Response Router::handle(const Request& req) { return *dispatch(req, true); }

std::string Router::base_url(const Request& req) const {
  if (!config_.public_url.empty()) return config_.public_url;
  const std::string scheme = req.forwarded_proto == "https" ? "https" : "http";
  return scheme + "://" + (host_is_sane(req.host) ? req.host : std::string("localhost"));
}

// The route table: every path the api serves, by method, in OpenAPI path-template syntax.
// api/openapi.json documents exactly these (RouterRoutes test) plus the server's /healthz,
// /readyz and /metrics. A template segment may hold parameters between literals
// ("{id}.dzi", "{quality}.{format}"); HEAD is answered as GET. The last field says who may call
// a route (api/authorize.h): every route states it, and every write needs a key.
const std::vector<Router::Route>& Router::routes() {
  static const std::vector<Route> table = {
      {"GET", "/", &Router::web_page, Access::kPublic},
      {"GET", "/{file}.js", &Router::web_script, Access::kPublic},
      {"GET", "/{file}.css", &Router::web_style, Access::kPublic},
      {"GET", "/v1", &Router::index, Access::kPublic},
      {"GET", "/openapi.json", &Router::openapi, Access::kPublic},
      {"GET", "/v1/methods", &Router::list_methods, Access::kPublic},
      {"GET", "/v1/images", &Router::list_images, Access::kPublic},
      {"POST", "/v1/images", &Router::upload_image, Access::kCurator},
      {"GET", "/v1/images/{id}", &Router::describe_image, Access::kPublic},
      {"DELETE", "/v1/images/{id}", &Router::delete_image, Access::kCurator},
      {"GET", "/v1/images/{id}/viewport", &Router::view_route, Access::kPublic},
      {"GET", "/v1/images/{id}/mesh", &Router::view_route, Access::kPublic},
      {"GET", "/v1/images/{id}/significance.png", &Router::view_route, Access::kPublic},
      {"GET", "/v1/images/{id}/lines", &Router::view_route, Access::kPublic},
      {"PUT", "/v1/images/{id}/lines", &Router::edit_route, Access::kCurator},
      {"PATCH", "/v1/images/{id}/significance", &Router::edit_route, Access::kCurator},
      {"GET", "/dzi/{id}.dzi", &Router::dzi_descriptor_route, Access::kPublic},
      {"GET", "/dzi/{id}_files/{level}/{tile}", &Router::dzi_tile_route, Access::kPublic},
      {"GET", "/iiif/3/{id}", &Router::iiif_base, Access::kPublic},
      {"GET", "/iiif/3/{id}/info.json", &Router::iiif_info, Access::kPublic},
      {"GET", "/iiif/3/{id}/{region}/{size}/{rotation}/{quality}.{format}", &Router::iiif_image, Access::kPublic},
      {"GET", "/v1/images/{id}/metadata", &Router::get_metadata, Access::kPublic},
      {"PUT", "/v1/images/{id}/metadata", &Router::put_metadata, Access::kCurator},
      // Before the collection's pages: an image may be called "collection".
      {"GET", "/iiif/presentation/3/{id}/manifest", &Router::iiif_manifest, Access::kPublic},
      {"GET", "/iiif/presentation/3/collection", &Router::iiif_collection, Access::kPublic},
      {"GET", "/iiif/presentation/3/collection/{page}", &Router::iiif_collection_page, Access::kPublic},
  };
  return table;
}

const Router::Route* Router::find_route(const std::string& req_method, const std::vector<std::string>& segments,
                                        PathParams& params, std::string& allowed) {
  const std::string method = req_method == "HEAD" ? "GET" : req_method;
  for (const Route& route : routes()) {
    if (!match_path(route.path, segments, params)) continue;
    if (route.method == method) return &route;
    allowed += (allowed.empty() ? "" : ", ") + std::string(route.method == "GET" ? "GET, HEAD" : route.method);
  }
  return nullptr;
}

std::optional<Response> Router::authorize(const Request& req) const {
  const auto segments = route_segments(req.path);
  if (!segments) return std::nullopt;
  PathParams params;
  std::string allowed;
  const Route* route = find_route(req.method, *segments, params, allowed);
  return route ? check_access(config_.access, route->access, req) : std::nullopt;
}

std::optional<Response> Router::dispatch(const Request& req, bool may_compute) {
  try {
    const auto segments = route_segments(req.path);
    if (!segments) throw ApiError(400, "invalid_path", "the path is not well-formed");
    reject_repeated_parameters(req.query);
    PathParams params;
    std::string allowed;
    if (const Route* route = find_route(req.method, *segments, params, allowed)) {
      if (auto refusal = check_access(config_.access, route->access, req)) return refusal;
      return (this->*route->handler)(req, params, may_compute);
    }
    if (!allowed.empty()) return method_not_allowed(allowed);
    if (segments->size() > 3 && (*segments)[0] == "iiif" && (*segments)[1] == "3")
      throw ApiError(400, "invalid_iiif_request",
                     "IIIF image requests are /iiif/3/{id}/{region}/{size}/{rotation}/{quality}.{format}");
    throw ApiError(404, "not_found", "no such route; see /openapi.json");
  } catch (const ApiError& e) {
    Response r = error_response(e);
    r.route = "error";
    return r;
  } catch (const tiles::StoreUnavailable&) {
    if (!may_compute) return std::nullopt;  // the I/O thread's: a worker asks the store
    throw;
  }
}

}  // namespace zoomwarp::api
