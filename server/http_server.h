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

#include "api/router.h"
#include "server/http_server_options.h"
#include "server/metrics.h"
#include "server/worker_pool.h"
#include "tiles/store.h"

namespace zoomwarp::server {

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
