// Image responses' one path (every answer that is a pure function of the image version and the
// request: views, tiles, IIIF images, descriptors, manifests): If-None-Match against the strong
// ETag, the encoded-response cache, the failure cache, and only then — if the caller may compute
// — the computation, once for identical concurrent requests (single flight). A failure that is the
// server's (api/errors.h server_failure_response) is answered with the route's label.
//
// Keys are "version|path|variant": a new version (an edit, a re-ingest) misses every entry of the
// old one, so the cache never needs invalidating.
//
// Thread safety: every member may be called from any thread at once (I/O threads and workers);
// the caches and the single-flight table lock inside. A Request's StopToken is only read.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "api/failure_cache.h"
#include "api/http_types.h"
#include "tiles/byte_lru_cache.h"
#include "tiles/single_flight.h"
#include "tiles/store.h"
#include "warp/core/stop_token.h"

namespace zoomwarp::api {

class CachedResponses {
 public:
  struct Options {
    std::size_t cache_bytes = 256u << 20;                     // the encoded-response cache
    std::chrono::milliseconds failure_window{5000};          // api/failure_cache.h; 0: never
    int cache_max_age = 60;                                   // Cache-Control max-age, seconds
    std::function<void(const Request&)> compute_hook;         // RouterConfig::compute_hook
  };
  explicit CachedResponses(Options options);

  // The answer for `req` on `entry`, labelled `route`; `key_extra` holds what besides the path
  // determines it (a view's canonical parameters, the base URL). nullopt when it must be computed
  // and `may_compute` is false (the I/O thread); otherwise `compute` runs — once for identical
  // concurrent requests — and its 200 is cached. The answer carries ETag, Last-Modified and
  // Cache-Control (private for a private image).
  std::optional<Response> image_response(const Request& req, const tiles::ImageEntry& entry, const std::string& route,
                                         const std::string& key_extra, bool may_compute,
                                         const std::function<Response(const tiles::ImageEntry&)>& compute);

  tiles::ByteLruCache<Response>::Stats cache_stats() const { return cache_.stats(); }
  std::size_t failure_cache_bytes() const { return failures_.bytes(); }

 private:
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

  const Options options_;
  tiles::ByteLruCache<Response> cache_;
  FailureCache failures_;
  tiles::SingleFlight<std::shared_ptr<const Response>> in_flight_;  // keeps nothing: cache_ keeps the answers
};

}  // namespace zoomwarp::api
