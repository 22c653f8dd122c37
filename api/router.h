// The REST surface of the product (api/openapi.json): image management (/v1/images), the warp
// engine's views (/v1/images/{id}/viewport and /mesh), the methods they take (/v1/methods) and
// curator edits (/lines, /significance),
// Deep Zoom (/dzi) and IIIF Image API 3.0 (/iiif/3). Operations endpoints (/healthz, /readyz, /metrics) belong to the
// server. Every answer is a pure function of the published image version and the request, which
// is what makes the ETags strong and the encoded-response cache safe.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "api/authorize.h"
#include "api/deepzoom.h"
#include "api/failure_cache.h"
#include "api/http_types.h"
#include "api/iiif.h"
#include "api/stored_tile_match.h"
#include "tiles/single_flight.h"
#include "api/url_signing.h"
#include "api/view_query.h"
#include "api/warp_engines.h"
#include "tiles/byte_lru_cache.h"
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
// and workers); the response cache, the single-flight table and the warp engines lock inside.
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

  tiles::ByteLruCache<Response>::Stats response_cache_stats() const { return cache_.stats(); }
  std::size_t failure_cache_bytes() const { return failures_.bytes(); }
  std::size_t warp_cache_bytes() { return engines_.memory_bytes(); }
  WarpEngines::Counts analysis_counts() const { return engines_.counts(); }
  // Tile answers computed by sending a stored JPEG tile as it is, without decoding (api/README.md,
  // "Stored tiles sent as they are"); answers from the response cache are not counted again.
  std::uint64_t tiles_passed_through() const { return passed_through_.load(std::memory_order_relaxed); }
  const RouterConfig& config() const { return config_; }

 // A route: method, OpenAPI path template, the member answering it, and who may call it (the
  // OpenAPI document declares the same as the route's `security`). A handler returns nullopt when
  // the answer must be computed and may_compute is false.
  using PathParams = std::vector<std::pair<std::string_view, std::string>>;
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
  static const std::string& param(const PathParams& params, std::string_view name);

  std::optional<Response> index(const Request&, const PathParams&, bool);
  // the web viewer (web/)
  std::optional<Response> web_page(const Request&, const PathParams&, bool);
  std::optional<Response> web_script(const Request&, const PathParams&, bool);
  std::optional<Response> web_style(const Request&, const PathParams&, bool);
  std::optional<Response> openapi(const Request&, const PathParams&, bool);
  // /v1/methods: the warp methods and saliency kinds a view request may name
  std::optional<Response> list_methods(const Request&, const PathParams&, bool);
  // /v1/images
  std::optional<Response> list_images(const Request&, const PathParams&, bool);
  std::optional<Response> describe_image(const Request&, const PathParams&, bool);
  std::optional<Response> delete_image(const Request&, const PathParams&, bool);
  std::optional<Response> upload_image(const Request&, const PathParams&, bool may_compute);
  Response describe(const tiles::ImageEntry& entry) const;
  // /v1/images/{id}/… of the warp engine (router_views.cc)
  std::optional<Response> view_route(const Request&, const PathParams&, bool may_compute);
  std::optional<Response> edit_route(const Request&, const PathParams&, bool may_compute);
  // /dzi, /iiif/3
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

  // Image responses go through one path: check If-None-Match, look in the cache, then in the
  // failure cache, and only then (if allowed) compute — once for identical concurrent requests
  // (single flight). A failure that is the server's (api/errors.h server_failure_response) is
  // answered with the route's label.
  std::optional<Response> image_response(const Request& req, const tiles::ImageEntry& entry,
                                         const std::string& route, const std::string& key_extra,
                                         bool may_compute,
                                         const std::function<Response(const tiles::ImageEntry&)>& compute);

  // Computes the response for `cache_key` once for identical concurrent requests (single flight).
  // Each requester is bound by its own `stop` only: a waiter that runs out of time leaves without
  // stopping the computation, and when the computing request is stopped by its token the
  // waiters do not fail with it, one of them computes in its place. Throws warp::Stopped, and
  // what `compute` throws. The computing request's deadline or internal error is remembered in
  // the failure cache (a client's error or cancellation is not); the waiters of that flight fare
  // as without it (a 500 reaches them, after a deadline one of them computes again).
  Response compute_once(const std::string& cache_key, const warp::StopToken* stop,
                        const std::function<Response()>& compute);
  // Runs `compute`; a failure that is the server's, but not a cancellation, is remembered under
  // `cache_key` (api/failure_cache.h) before it is rethrown.
  Response compute_remembering_failure(const std::string& cache_key, const std::function<Response()>& compute);

  // The stored JPEG tile `tile` as the whole answer (api/stored_tile_match.h), counted.
  Response stored_tile_response(const tiles::ImageEntry& entry, const StoredTileRef& tile);
  // An IIIF image read, resampled, rotated, filtered and encoded (every request that is not a
  // stored tile).
  Response encoded_iiif_response(const tiles::ImageEntry& entry, const IiifPlan& plan);

  std::string base_url(const Request& req) const;

  // Private images (tiles::Manifest::is_private): whether the request carries a curator (or admin)
  // key.
  bool has_curator_key(const Request& req) const;
  // The image `id` for reading, like find_image(). A private image only for a curator key or a
  // validly signed URL; otherwise 404 image_not_found exactly as for an image that does not exist
  // (a private image's existence is not revealed), and 403 url_expired / bad_signature for a
  // signed URL that fails. Every read route calls this before its cache lookup or 304, so a cached
  // answer is never served around the check.
  std::shared_ptr<const tiles::ImageEntry> readable_image(const Request& req, const std::string& id) const;
  // The image of an IIIF Image service segment: readable_image() for a plain id; for a service
  // segment ID~EXPIRES~SIG (api/url_signing.h, a private manifest's service) the image when the
  // token is valid, 403 url_expired / bad_signature when not.
  std::shared_ptr<const tiles::ImageEntry> readable_service(const Request& req, const std::string& segment) const;

  tiles::Store& store_;
  tiles::PyramidReader& reader_;
  RouterConfig config_;
  tiles::ByteLruCache<Response> cache_;
  FailureCache failures_;
  WarpEngines engines_;
  tiles::StoredTiles stored_tiles_;
  std::atomic<std::uint64_t> passed_through_{0};
  tiles::SingleFlight<std::shared_ptr<const Response>> in_flight_;  // keeps nothing: cache_ keeps the answers
};

}  // namespace zoomwarp::api
