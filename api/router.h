// The REST surface of the product (api/openapi.json): the route table — OpenAPI path templates,
// each with its handler and who may call it — and the dispatch that matches a request against it
// (api/route_match.h) and checks its access (api/authorize.h) before the handler runs. The
// handlers are grouped by what they serve, one file each: router_site.cc (the web viewer, /v1,
// /openapi.json, /v1/methods), router_images.cc (/v1/images), router_views.cc (the warp
// engine's views and curator edits), router_tiles.cc (Deep Zoom and IIIF Image API 3.0),
// router_presentation.cc (the curator's description and IIIF Presentation 3.0). Operations
// endpoints (/healthz, /readyz, /metrics) belong to the server.
//
// Every image answer is a pure function of the published image version and the request, which is
// what makes the ETags strong and the encoded-response cache safe (api/cached_responses.h); a
// private image is read only through api/image_access.h.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "api/authorize.h"
#include "api/cached_responses.h"
#include "api/collection_index.h"
#include "api/framed_views.h"
#include "api/deepzoom.h"
#include "api/http_types.h"
#include "api/iiif.h"
#include "api/image_access.h"
#include "api/route_match.h"
#include "api/stored_tile_match.h"
#include "api/url_signing.h"
#include "api/warp_engines.h"
#include "tiles/encode.h"
#include "tiles/ingest.h"
#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "tiles/stored_tiles.h"

namespace zoomwarp::api {

struct RouterConfig {
  std::size_t response_cache_bytes = 256u << 20;  // encoded-response cache
  tiles::EncodeOptions encode;
  IiifLimits iiif;
  DziLayout dzi;
  tiles::IngestOptions ingest;
  std::string public_url;  // e.g. "https://tiles.example.org"; empty: from Host / X-Forwarded-Proto
  int cache_max_age = 60;  // Cache-Control max-age of image responses, seconds
  std::size_t warp_cache_bytes = 256u << 20;  // ICAZ operators (models, forests, coarse warps) kept in memory
  warp::SignificanceOptions significance;     // for models built from the pyramid (the face cascade)
  int analysis_threads = 1;                   // background threads computing analyses on first use (warp_engines.h)
  EventLog log;                               // damaged models are reported here
  AccessPolicy access;                        // who may call the curator routes (api/authorize.h)
  // Verifies signed URLs of private images (api/url_signing.h); null: none is valid (no
  // --signing-key). Curator keys are the access policy's.
  std::shared_ptr<const UrlSigner> url_signer;
  // How long a view's failure (deadline, 500) is answered from memory (api/failure_cache.h); 0: never.
  std::chrono::milliseconds failure_cache_window{5000};
  // Test builds only (tests/support/compute_hook_poison.cc): called on the worker just before an
  // image response is computed, within its single flight and failure cache. Empty in the shipped
  // binary (server/compute_hook.h).
  std::function<void(const Request&)> compute_hook;
};

// Threads: try_answer_now() and handle() may be called concurrently from any threads (I/O threads
// and workers); the response caches, the single-flight table and the warp engines lock inside.
// A Request's StopToken is read only.
class Router {
 public:
  Router(tiles::Store& store, tiles::PyramidReader& reader, RouterConfig config);

  // Answers at once what needs no decoding or encoding: cached responses, 304s, descriptors,
  // metadata, errors. Returns nullopt when the answer must be computed; then call handle(),
  // preferably on a worker thread.
  std::optional<Response> try_answer_now(const Request& req);

  // Answers any request; may decode, resample, encode or ingest.
  Response handle(const Request& req);

  // The 401/403 answer if `req` names a route its credentials do not allow (api/authorize.h),
  // else nullopt (also for paths no route has: dispatch answers those). dispatch() checks this
  // before every handler; the server also asks before reading an upload's body, so a refused
  // upload costs no disk.
  std::optional<Response> authorize(const Request& req) const;

  // Whether the request's body is an image upload that the server streams into a file
  // (Request::body_file) instead of memory.
  static bool is_upload(std::string_view method, std::string_view path);

  tiles::ByteLruCache<Response>::Stats response_cache_stats() const { return responses_.cache_stats(); }
  std::size_t failure_cache_bytes() const { return responses_.failure_cache_bytes(); }
  std::size_t warp_cache_bytes() { return engines_.memory_bytes(); }
  WarpEngines::Counts analysis_counts() const { return engines_.counts(); }
  // Tile answers computed by sending a stored JPEG tile as it is, without decoding (api/README.md,
  // "Stored tiles sent as they are"); answers from the response cache are not counted again.
  std::uint64_t tiles_passed_through() const { return passed_through_.load(std::memory_order_relaxed); }
  const RouterConfig& config() const { return config_; }

  // A route: method, OpenAPI path template, the member answering it, and who may call it (the
  // OpenAPI document declares the same as the route's `security`). A handler returns nullopt when
  // the answer must be computed and may_compute is false.
  using Handler = std::optional<Response> (Router::*)(const Request&, const PathParams&, bool may_compute);
  struct Route {
    std::string_view method;
    std::string_view path;
    Handler handler;
    Access access;  // no default: a route says who may call it
  };
  static const std::vector<Route>& routes();

 private:
  std::optional<Response> dispatch(const Request& req, bool may_compute);
  // The route matching `method` and the path's segments (parameters into `params`), or null;
  // `allowed` gathers the methods of routes with the same path.
  static const Route* find_route(const std::string& method, const std::vector<std::string>& segments,
                                 PathParams& params, std::string& allowed);

  // the web viewer (web/), /v1, /openapi.json, /v1/methods (router_site.cc)
  std::optional<Response> index(const Request&, const PathParams&, bool);
  std::optional<Response> web_page(const Request&, const PathParams&, bool);
  std::optional<Response> web_script(const Request&, const PathParams&, bool);
  std::optional<Response> web_style(const Request&, const PathParams&, bool);
  std::optional<Response> openapi(const Request&, const PathParams&, bool);
  std::optional<Response> list_methods(const Request&, const PathParams&, bool);
  // /v1/images (router_images.cc)
  std::optional<Response> list_images(const Request&, const PathParams&, bool);
  std::optional<Response> describe_image(const Request&, const PathParams&, bool);
  std::optional<Response> delete_image(const Request&, const PathParams&, bool);
  std::optional<Response> upload_image(const Request&, const PathParams&, bool may_compute);
  Response describe(const tiles::ImageEntry& entry) const;
  // /v1/images/{id}/… of the warp engine (router_views.cc)
  std::optional<Response> view_route(const Request&, const PathParams&, bool may_compute);
  std::optional<Response> edit_route(const Request&, const PathParams&, bool may_compute);
  // /dzi, /iiif/3 (router_tiles.cc)
  std::optional<Response> dzi_descriptor_route(const Request&, const PathParams&, bool);
  std::optional<Response> dzi_tile_route(const Request&, const PathParams&, bool may_compute);
  std::optional<Response> iiif_base(const Request&, const PathParams&, bool);
  std::optional<Response> iiif_info(const Request&, const PathParams&, bool);
  std::optional<Response> iiif_image(const Request&, const PathParams&, bool may_compute);
  // /v1/images/{id}/metadata and IIIF Presentation 3.0 (router_presentation.cc)
  std::optional<Response> get_metadata(const Request&, const PathParams&, bool);
  std::optional<Response> put_metadata(const Request&, const PathParams&, bool may_compute);
  std::optional<Response> iiif_manifest(const Request&, const PathParams&, bool may_compute);
  std::optional<Response> iiif_collection(const Request&, const PathParams&, bool may_compute);
  std::optional<Response> iiif_collection_page(const Request&, const PathParams&, bool may_compute);

  // The stored JPEG tile `tile` as the whole answer (api/stored_tile_match.h), counted.
  Response stored_tile_response(const tiles::ImageEntry& entry, const StoredTileRef& tile);
  // An IIIF image read, resampled, rotated, filtered and encoded (every request that is not a
  // stored tile).
  Response encoded_iiif_response(const tiles::ImageEntry& entry, const IiifPlan& plan);

  std::string base_url(const Request& req) const;

  tiles::Store& store_;
  tiles::PyramidReader& reader_;
  RouterConfig config_;
  ImageAccess access_;
  CachedResponses responses_;
  WarpEngines engines_;
  ViewFraming framing_{engines_};  // fit= of /viewport and /mesh (api/framed_views.h)
  CollectionIndex collection_{store_, config_.log};  // the IIIF collection's public images
  tiles::StoredTiles stored_tiles_;
  std::atomic<std::uint64_t> passed_through_{0};
};

}  // namespace zoomwarp::api
