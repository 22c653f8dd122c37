// The HTTP/1.1 server (Boost.Beast, keep-alive): a listener accepts connections, one session per
// connection reads requests and writes responses on the I/O threads; anything that needs CPU
// (rendering, encoding, ingest) goes to a bounded worker pool and comes back to the session.
// SIGHUP calls HttpServerOptions::on_reload (the key file is read again) and changes nothing else.
// SIGTERM/SIGINT drains: readiness fails, then no new connections, idle connections close,
// in-flight requests finish, and run() returns 0. Requests still running when --drain-timeout has
// passed are cancelled (their StopTokens) and get what they can in a last half second; then run()
// returns 0 all the same (the stop was asked for and kept its time; the log says "drain timed
// out"). Workers may then still be in work that checks no token (an ingest, a large IIIF decode)
// and hold sessions: a caller whose pools are not idle must end the process at once (std::_Exit)
// rather than destroy the server or wait for the pools.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "api/rate_limits.h"
#include "api/router.h"
#include "server/cors.h"
#include "server/metrics.h"
#include "server/worker_pool.h"
#include "tiles/store.h"

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

// Threads: construct, run() and destroy on one thread; run() runs the I/O threads itself.
class HttpServer {
 public:
  HttpServer(HttpServerOptions options, tiles::Store& store, api::Router& router, WorkerPool& cpu,
             WorkerPool& ingest, Metrics& metrics);
  ~HttpServer();

  // Serves until a termination signal has been drained. Returns the process exit code.
  // Throws std::runtime_error if it cannot listen.
  int run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace zoomwarp::server
