// What the HTTP server is told at start (`zoomwarp serve`'s flags, server/serve_command.cc): where
// it listens, its limits and timeouts, its CORS and upload-rate policies. Plain data, read by the
// server (http_server.h) and by every session (session.h).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include "api/rate_limits.h"
#include "server/cors.h"

namespace zoomwarp::server {

struct HttpServerOptions {
  std::string host = "127.0.0.1";
  int port = 8080;  // 0 picks a free port (logged in the "listening" line)
  int io_threads = 2;
  std::uint64_t max_upload_bytes = 512ull << 20;
  std::uint64_t max_body_bytes = 1ull << 20;  // non-upload bodies (JSON)
  std::chrono::seconds idle_timeout{30};      // keep-alive connections and slow clients
  std::chrono::seconds header_timeout{10};    // from a request's first bytes to the end of its header
  std::chrono::seconds body_timeout{30};      // longest pause between two pieces of an upload's body
  std::size_t upload_slots = 5;               // uploads admitted at once: ingest threads + queue places
  std::uint64_t max_staging_bytes = 0;        // upload bytes staged at once (0: no cap but the slots)
  std::size_t max_connections = 1024;         // open connections; more wait in the listen backlog
  std::chrono::seconds drain_delay{0};        // after SIGTERM: not ready, still serving
  std::chrono::seconds drain_timeout{30};     // then at most this long for in-flight requests
  std::chrono::seconds request_timeout{5};    // computed requests, from read to answer (queue included)
  std::chrono::seconds gc_interval{60};       // store garbage collection
  std::chrono::milliseconds store_check_interval{1000};  // how often readiness asks the store
  std::chrono::milliseconds store_check_timeout{2000};   // and how long it waits for an answer
  std::chrono::seconds gc_grace{600};         // age of unreferenced versions before removal
  bool log_requests = true;
  std::string face_detection = "on";          // "off: why" — a /readyz detail, not a readiness failure
  CorsPolicy cors;                            // which origins may write (server/cors.h)
  // The client address (rate limits) is the last X-Forwarded-For entry, the one our proxy added,
  // instead of the peer's; only behind a proxy that sets it, or clients choose their address.
  bool trust_forwarded_for = false;
  api::RateLimitConfig upload_limits;         // uploads per minute and bytes per day, per key or address
  std::function<void()> on_reload;            // SIGHUP, on an I/O thread; empty: SIGHUP is logged and ignored
};

}  // namespace zoomwarp::server
