#include "api/router.h"

#include <filesystem>
#include <fstream>
#include <chrono>
#include <map>
#include <set>
#include <nlohmann/json.hpp>

#include "api/assets.h"
#include "api/errors.h"
#include "api/responses.h"
#include "api/http_caching.h"
#include "api/presentation.h"
#include "api/url.h"
#include "tiles/image_id.h"
#include "tiles/store_deadline.h"
#include "tiles/store_errors.h"
#include "warp/analysis/derived_files.h"
#include "tiles/raster_ops.h"

namespace zoomwarp::api {

namespace {

using nlohmann::json;

Response json_response(int status, const json& body) {
  Response r;
  r.status = status;
  r.content_type = "application/json";
  r.body = std::make_shared<const std::string>(body.dump(2) + "\n");
  return r;
}

json image_json(const tiles::Manifest& m) {
  return {{"id", m.id},
          {"width", m.width},
          {"height", m.height},
          {"levels", m.levels},
          {"tile_size", m.tile_size},
          {"version", m.version},
          {"status", "ready"},
          {"private", m.is_private},
          {"channels", m.channels},
          {"created", http_date(m.created_ms)},
          {"source", {{"format", m.source_format}, {"bits", m.source_bits}, {"bytes", m.source_bytes}}},
          {"links",
           {{"self", "/v1/images/" + m.id},
            {"dzi", "/dzi/" + m.id + ".dzi"},
            {"iiif", "/iiif/3/" + m.id + "/info.json"},
            {"manifest", manifest_path(m.id)},
            {"metadata", "/v1/images/" + m.id + "/metadata"}}}};
}

// The default id of an upload: a digest of its bytes.
std::string content_id(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::uint64_t h = kFnvOffset;
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) h = fnv1a64(std::string_view(buf, std::size_t(in.gcount())), h);
  return "img-" + hex64(h);
}

// An upload's private=: true/1 or false/0, nothing else.
bool parse_private_flag(const std::string& v) {
  if (v == "true" || v == "1") return true;
  if (v == "false" || v == "0") return false;
  throw ApiError(400, "invalid_query", "private must be true, 1, false or 0, not '" + v + "'");
}

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

// A signed URL's or service token's verdict, other than kUnsigned: 403 unless it is valid.
void refuse_unless_valid(UrlSigner::Verdict verdict) {
  using Verdict = UrlSigner::Verdict;
  if (verdict == Verdict::kExpired) throw ApiError(403, "url_expired", "this signed URL has expired; ask for a new one");
  if (verdict != Verdict::kValid)
    throw ApiError(403, "bad_signature", "the signature does not match this URL (path, query and expiry are signed)");
}

bool host_is_sane(std::string_view h) {
  if (h.empty() || h.size() > 255) return false;
  for (char c : h)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == ':' || c == '[' || c == ']'))
      return false;
  return true;
}

// The failure cache's memory: a remembered failure is its key and a ~150-byte error body, so this
// holds a few thousand; a flood of distinct failing requests only evicts older ones.
constexpr std::size_t kFailureCacheBytes = 1u << 20;

tiles::Raster apply_quality(tiles::Raster r, IiifQuality q) {
  switch (q) {
    case IiifQuality::kGray: return tiles::to_grey(r);
    case IiifQuality::kBitonal: return tiles::to_bitonal(r);
    default: return r;
  }
}

}  // namespace

Router::Router(tiles::Store& store, tiles::PyramidReader& reader, RouterConfig config)
    : store_(store),
      reader_(reader),
      config_(std::move(config)),
      cache_(config_.response_cache_bytes),
      failures_(config_.failure_cache_window, kFailureCacheBytes),
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

bool Router::has_curator_key(const Request& req) const {
  const Authenticator* keys = config_.access.keys;
  if (!keys || req.authorization.empty()) return false;
  const auto result = keys->authenticate(req.authorization);
  return result.outcome == Authenticator::Outcome::kValid && result.principal.role >= Role::kCurator;
}

std::shared_ptr<const tiles::ImageEntry> Router::readable_image(const Request& req, const std::string& id) const {
  auto entry = find_image(store_, id);
  if (!entry->manifest.is_private || has_curator_key(req)) return entry;
  const auto now = std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch());
  using Verdict = UrlSigner::Verdict;
  const Verdict verdict = config_.url_signer ? config_.url_signer->verify(req.path, req.query, now.count())
                                             : Verdict::kUnsigned;
  if (verdict != Verdict::kUnsigned) {
    refuse_unless_valid(verdict);
    return entry;
  }
  // The same answer as for an id that does not exist (responses.cc find_image).
  throw ApiError(404, "image_not_found", "no image with id '" + id + "'");
}

std::shared_ptr<const tiles::ImageEntry> Router::readable_service(const Request& req, const std::string& segment) const {
  const std::size_t tilde = segment.find('~');
  if (tilde == std::string::npos) return readable_image(req, segment);
  std::string id = segment.substr(0, tilde);
  check_image_id(id);
  if (!config_.url_signer)
    throw ApiError(403, "bad_signature", "this server has no signing key, so no service token is valid");
  const auto now = std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch());
  refuse_unless_valid(config_.url_signer->verify_service(segment, now.count(), &id));
  return find_image(store_, id);
}

std::optional<Response> Router::image_response(const Request& req, const tiles::ImageEntry& entry,
                                               const std::string& route, const std::string& key_extra,
                                               bool may_compute,
                                               const std::function<Response(const tiles::ImageEntry&)>& compute) {
  const tiles::Manifest& m = entry.manifest;
  const std::string key = req.path + "|" + key_extra;
  // Made only where needed: a cache hit carries its own (one string and one hash fewer per hit).
  auto with_validators = [&](Response r) {
    r.route = route;
    r.set_header("ETag", make_etag(m.version, key));
    r.set_header("Last-Modified", http_date(m.created_ms));
    // A private image's answers are for this client only: a shared cache (nginx) must not keep them.
    r.set_header("Cache-Control", std::string(m.is_private ? "private" : "public") +
                                      ", max-age=" + std::to_string(config_.cache_max_age));
    return r;
  };
  if (!req.if_none_match.empty() && if_none_match_matches(req.if_none_match, make_etag(m.version, key))) {
    Response r;
    r.status = 304;
    return with_validators(std::move(r));
  }
  const std::string cache_key = m.version + "|" + key;
  if (auto hit = cache_.get(cache_key)) {
    Response r = *hit;
    r.cache = "hit";
    return r;
  }
  if (auto failed = failures_.get(cache_key)) {
    failed->route = route;
    return failed;
  }
  if (!may_compute) return std::nullopt;
  try {
    return compute_once(cache_key, req.stop, [&] {
      if (config_.compute_hook) config_.compute_hook(req);
      return with_validators(compute(entry));
    });
  } catch (...) {
    auto failed = server_failure_response(std::current_exception());
    if (!failed) throw;
    failed->route = route;
    return failed;
  }
}

namespace {
// Waits for another request's computation as long as `stop` allows; throws Stopped when it ends.
void wait_for(const std::shared_future<std::shared_ptr<const Response>>& pending, const warp::StopToken* stop) {
  if (!stop) return pending.wait();
  while (pending.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) stop->check();
}
}  // namespace

Response Router::compute_remembering_failure(const std::string& cache_key, const std::function<Response()>& compute) {
  try {
    return compute();
  } catch (...) {
    // Not a request that was cancelled (its client left: nothing is wrong with the view), nor the
    // client's own error (as cheap to find again as to remember), nor the store's (nothing is
    // wrong with the view either; while the store is known down, asking it costs nothing, and the
    // view is served again as soon as it answers).
    const auto failed = server_failure_response(std::current_exception());
    if (failed && failed->failure != "cancelled" && failed->failure != "store") failures_.put(cache_key, *failed);
    throw;
  }
}

Response Router::compute_once(const std::string& cache_key, const warp::StopToken* stop,
                              const std::function<Response()>& compute) {
  while (true) {
    warp::check_stop(stop);  // out of time or cancelled while queued: not computed at all
    // Single flight: the first request for a key computes, identical ones arriving meanwhile wait
    // for its answer (a burst of clients opening the same view costs one warp and one encode).
    bool computing = false;
    try {
      const auto [answer, computed] = in_flight_.get(
          cache_key,
          [&] {
            computing = true;
            auto r = std::make_shared<const Response>(compute_remembering_failure(cache_key, compute));
            // Cached before the flight lands, so that a request arriving after it finds the answer.
            if (r->status == 200) cache_.put(cache_key, r, r->body->size());
            return r;
          },
          [&](const auto& pending) { wait_for(pending, stop); });  // a waiter that runs out of time leaves
      Response r = *answer;
      r.cache = computed ? "miss" : "hit";
      return r;
    } catch (const warp::Stopped&) {
      if (computing) throw;
      warp::check_stop(stop);  // this request's own time ran out, or its client left, while waiting
      // The computing request's own client left or it ran out of time: not ours; compute it here.
    }
  }
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

namespace {

// Matches one decoded path segment against a template segment, appending its parameters. A
// parameter takes at least one character and runs to the next literal (the last occurrence for
// the template's last literal, so "a.b.png" against "{x}.{format}" gives x = "a.b").
bool match_segment(std::string_view tmpl, std::string_view seg, Router::PathParams& params) {
  std::size_t t = 0, pos = 0;
  while (t < tmpl.size()) {
    if (tmpl[t] != '{') {
      const std::size_t lit_end = std::min(tmpl.find('{', t), tmpl.size());
      const std::string_view lit = tmpl.substr(t, lit_end - t);
      if (seg.substr(pos, lit.size()) != lit) return false;
      pos += lit.size(), t = lit_end;
      continue;
    }
    const std::size_t close = tmpl.find('}', t);
    const std::string_view name = tmpl.substr(t + 1, close - t - 1);
    t = close + 1;
    std::size_t value_end = seg.size();
    if (t < tmpl.size()) {
      const std::size_t lit_end = std::min(tmpl.find('{', t), tmpl.size());
      const std::string_view lit = tmpl.substr(t, lit_end - t);
      const bool last_literal = tmpl.find('{', lit_end) == std::string_view::npos;
      value_end = last_literal ? seg.rfind(lit) : seg.find(lit, pos + 1);
      if (value_end == std::string_view::npos || value_end <= pos) return false;
    }
    if (value_end <= pos) return false;
    params.emplace_back(name, std::string(seg.substr(pos, value_end - pos)));
    pos = value_end;
  }
  return pos == seg.size();
}

bool match_path(std::string_view tmpl, const std::vector<std::string>& segments, Router::PathParams& params) {
  params.clear();
  std::size_t i = 0, t = 1;  // both start with '/'
  while (t <= tmpl.size()) {
    const std::size_t end = std::min(tmpl.find('/', t), tmpl.size());
    if (i >= segments.size() || !match_segment(tmpl.substr(t, end - t), segments[i], params)) return false;
    ++i, t = end + 1;
  }
  return i == segments.size();
}

// The decoded segments routes match against (a trailing slash ignored: "/v1/images/"); nullopt
// for a malformed path.
std::optional<std::vector<std::string>> route_segments(std::string_view path) {
  auto segments = split_path(path);
  if (segments && segments->size() > 1 && segments->back().empty()) segments->pop_back();
  return segments;
}

}  // namespace

const std::string& Router::param(const PathParams& params, std::string_view name) {
  for (const auto& [k, v] : params)
    if (k == name) return v;
  throw std::logic_error("route parameter missing from the template");
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
    for (const MethodDescription& m : view_methods())
      methods.push_back({{"name", std::string(m.name)},
                         {"summary", std::string(m.summary)},
                         {"zoom", std::string(m.zoom)},
                         {"mesh", m.has_mesh},
                         {"lines", m.lines.empty() ? json(nullptr) : json(std::string(m.lines))}});
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

std::optional<Response> Router::dzi_descriptor_route(const Request& req, const PathParams& p, bool) {
  return image_response(req, *readable_image(req, param(p, "id")), "dzi_descriptor", "", true,
                        [&](const tiles::ImageEntry& e) {
                          return body_response("application/xml", dzi_descriptor(e.manifest, config_.dzi,
                                                                                 e.manifest.has_alpha() ? "png" : "jpg"));
                        });
}

std::optional<Response> Router::dzi_tile_route(const Request& req, const PathParams& p, bool may_compute) {
  auto level = parse_small_uint(param(p, "level"));
  auto name = parse_dzi_tile_name(param(p, "tile"));
  if (!level || !name)
    throw ApiError(400, "invalid_tile", "tile paths are /dzi/{id}_files/{level}/{col}_{row}.{jpg|png|webp}");
  auto format = tiles::format_from_extension(name->extension);
  if (!format) throw ApiError(400, "invalid_format", "tile format must be jpg, png, webp, avif or jxl");
  auto entry = readable_image(req, param(p, "id"));
  auto tile = dzi_tile(entry->manifest, config_.dzi, *level, name->col, name->row);
  if (!tile)
    throw ApiError(404, "tile_not_found",
                   "no tile " + std::to_string(name->col) + "_" + std::to_string(name->row) + " at level " +
                       std::to_string(*level) + " (levels 0-" + std::to_string(entry->manifest.levels - 1) + ")");
  return image_response(req, *entry, "dzi_tile", "", may_compute, [&](const tiles::ImageEntry& e) {
    if (auto stored = dzi_stored_tile(e.manifest, config_.dzi, *tile, *format)) return stored_tile_response(e, *stored);
    tiles::Raster pixels = reader_.read_level(e, tile->store_level, tile->rect);
    return body_response(std::string(tiles::mime_type(*format)), tiles::encode_image(pixels, *format, config_.encode));
  });
}

// IIIF base URI: redirect to the image information (§2.1).
std::optional<Response> Router::iiif_base(const Request& req, const PathParams& p, bool) {
  readable_service(req, param(p, "id"));
  Response r;
  r.status = 303;
  r.route = "iiif_base";
  r.set_header("Location", req.path + "/info.json");
  return r;
}

std::optional<Response> Router::iiif_info(const Request& req, const PathParams& p, bool) {
  const std::string base = base_url(req);
  const bool ld = req.accept.find("application/ld+json") != std::string::npos;
  // The service's id is the segment asked for: a private manifest's service token stays in it, so
  // the viewer's tile requests carry it too.
  const std::string& segment = param(p, "id");
  return image_response(req, *readable_service(req, segment), "iiif_info", base + (ld ? "|ld" : ""), true,
                        [&](const tiles::ImageEntry& e) {
                          Response r = body_response(
                              ld ? "application/ld+json;profile=\"http://iiif.io/api/image/3/context.json\""
                                 : "application/json",
                              iiif_info_json(e.manifest, base + "/iiif/3/" + segment, base, config_.iiif));
                          r.set_header("Link", "<http://iiif.io/api/image/3/level2.json>;rel=\"profile\"");
                          return r;
                        });
}

std::optional<Response> Router::iiif_image(const Request& req, const PathParams& p, bool may_compute) {
  auto entry = readable_service(req, param(p, "id"));
  const IiifPlan plan =
      plan_iiif_request(param(p, "region"), param(p, "size"), param(p, "rotation"),
                        param(p, "quality") + "." + param(p, "format"), entry->manifest.width, entry->manifest.height,
                        config_.iiif);
  return image_response(req, *entry, "iiif_image", "", may_compute, [&](const tiles::ImageEntry& e) {
    const auto stored = iiif_stored_tile(e.manifest, plan);
    Response r = stored ? stored_tile_response(e, *stored) : encoded_iiif_response(e, plan);
    r.set_header("Link", "<http://iiif.io/api/image/3/level2.json>;rel=\"profile\"");
    return r;
  });
}

Response Router::encoded_iiif_response(const tiles::ImageEntry& entry, const IiifPlan& plan) {
  tiles::Raster pixels = reader_.read_scaled(entry, plan.region, plan.width, plan.height);
  if (plan.mirror) pixels = tiles::mirror_horizontally(pixels);
  pixels = tiles::rotate_clockwise(pixels, plan.rotation);
  pixels = apply_quality(std::move(pixels), plan.quality);
  std::string body;
  try {
    body = tiles::encode_image(pixels, plan.format, config_.encode);
  } catch (const std::invalid_argument& err) {
    throw ApiError(400, "invalid_iiif_request", err.what());
  }
  return body_response(std::string(tiles::mime_type(plan.format)), std::move(body));
}

Response Router::stored_tile_response(const tiles::ImageEntry& entry, const StoredTileRef& tile) {
  Response r = body_response(std::string(tiles::mime_type(tiles::ImageFormat::kJpeg)),
                             stored_tiles_.jpeg_tile(entry, tile.level, tile.tx, tile.ty));
  passed_through_.fetch_add(1, std::memory_order_relaxed);
  return r;
}

// Private images are listed for curator keys only; such a list is for that client alone.
std::optional<Response> Router::list_images(const Request& req, const PathParams&, bool) {
  const bool curator = has_curator_key(req);
  json images = json::array();
  for (const auto& entry : store_.list())
    if (curator || !entry->manifest.is_private) images.push_back(image_json(entry->manifest));
  Response r = json_response(200, {{"images", images}});
  r.route = "images_list";
  r.set_header("Cache-Control", curator ? "private, no-cache" : "no-cache");
  return r;
}

std::optional<Response> Router::describe_image(const Request& req, const PathParams& p, bool) {
  return describe(*readable_image(req, param(p, "id")));
}

Response Router::describe(const tiles::ImageEntry& entry) const {
  json j = image_json(entry.manifest);
  // Which analyses the version holds (issue 28: made on first use, or by `zoomwarp analyse`).
  j["analyses"] = warp::stored_analyses(entry);
  Response r = json_response(200, j);
  r.route = "image_get";
  r.set_header("ETag", make_etag(entry.manifest.version, "image"));
  r.set_header("Cache-Control", entry.manifest.is_private ? "private, no-cache" : "no-cache");
  return r;
}

std::optional<Response> Router::delete_image(const Request&, const PathParams& p, bool) {
  const std::string& id = param(p, "id");
  check_image_id(id);
  // An image whose manifest is damaged cannot be found, but it can be removed.
  const auto entry = store_.find(id);
  if (!store_.remove(id)) throw ApiError(404, "image_not_found", "no image with id '" + id + "'");
  if (entry) reader_.forget(*entry);
  Response r;
  r.status = 204;
  r.route = "image_delete";
  return r;
}

std::optional<Response> Router::upload_image(const Request& req, const PathParams&, bool may_compute) {
  if (!may_compute) return std::nullopt;
  auto query = parse_query(req.query);
  if (!query) throw ApiError(400, "invalid_query", "the query string is not well-formed");
  std::string id;
  tiles::IngestOptions options = config_.ingest;
  std::map<std::string, std::string> description_fields;
  for (const auto& [k, v] : *query) {
    if (k == "id") id = v;
    else if (k == "private") options.is_private = parse_private_flag(v);
    else if (k == "label" || k == "summary" || k == "rights" || k == "attribution") description_fields[k] = v;
    else
      throw ApiError(400, "invalid_query",
                     "unknown parameter '" + k + "' (id, private, label, summary, rights and attribution are accepted)");
  }
  std::error_code ec;
  if (req.body_file.empty() || std::filesystem::file_size(req.body_file, ec) == 0 || ec)
    throw ApiError(400, "empty_body", "send the image file as the request body");
  if (id.empty()) id = content_id(req.body_file);
  if (!tiles::is_valid_image_id(id))
    throw ApiError(400, "invalid_id",
                   "image ids are 1-128 characters from A-Z a-z 0-9 . _ - and start with a letter or digit");
  if (!description_fields.empty()) {
    // Laid over the description the image has (a re-upload giving a label keeps the rest), and
    // published with the pixels in one version.
    const auto published = store_.find(id);
    const Description d =
        description_with_upload_fields(published ? read_description(*published) : Description{}, description_fields);
    options.analyse = [d, analyse = options.analyse](const tiles::ImageEntry& staged) {
      if (analyse) analyse(staged);
      staged.files->write(kDescriptionFile, description_json(d));
    };
  }
  try {
    tiles::Manifest m = tiles::ingest_image(store_, req.body_file, id, options);
    Response r = json_response(201, image_json(m));
    r.route = "image_upload";
    r.set_header("Location", "/v1/images/" + m.id);
    return r;
  } catch (const tiles::IngestError& e) {
    using Kind = tiles::IngestError::Kind;
    switch (e.kind()) {
      case Kind::kUnsupportedFormat: throw ApiError(415, "unsupported_format", without_paths(e.what()), e.what());
      case Kind::kTooLarge: throw ApiError(413, "image_too_large", without_paths(e.what()), e.what());
      case Kind::kCorrupt: throw ApiError(422, "corrupt_image", without_paths(e.what()), e.what());
      case Kind::kIo: throw ApiError(500, "store_error", "the image could not be stored", e.what());
    }
    throw;
  }
}

}  // namespace zoomwarp::api
