#include "server/http_server.h"

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <nlohmann/json.hpp>
#include <memory>
#include <thread>
#include <vector>

#include "server/listener.h"
#include "server/log.h"
#include "server/session.h"
#include "tiles/store_deadline.h"

namespace zoomwarp::server {

namespace net = boost::asio;
using tcp = net::ip::tcp;
using namespace std::chrono_literals;

struct HttpServer::Impl {
  Impl(HttpServerOptions options, tiles::Store& store, api::Router& router, WorkerPool& cpu,
       WorkerPool& ingest, Metrics& metrics)
      : state(std::move(options), store, router, cpu, ingest, metrics),
        ioc(1),
        signals(ioc, SIGINT, SIGTERM),
        reload_signals(ioc, SIGHUP),
        drain_timer(ioc),
        gc_timer(ioc) {
    // ioc (signals, timers, the listener) also takes sessions; every context has one thread.
    for (int i = 1; i < state.options.io_threads; ++i) more_contexts.push_back(std::make_unique<net::io_context>(1));
    metrics.add_sampler([this] { return store_samples(); });
  }

  // The store's metrics: its readiness and image count as last checked (StoreMonitor), and for a
  // bucket the requests made (what S3 bills) and what its cache holds.
  std::vector<Metrics::Sample> store_samples() const {
    using S = Metrics::Sample;
    const StoreMonitor::Reading r = state.store_monitor.last();
    const tiles::StoreStats s = state.store.stats();
    // A folder's count is one directory listing, made here; a bucket's is never waited for here.
    std::vector<S> out = {
        {"zoomwarp_images", "Images published in the store (a bucket's as of its last count, every ten seconds).",
         "gauge", "", double(s.remote ? r.images : state.store.count())},
        {"zoomwarp_store_readable", "1 when the store answered its last readiness check.", "gauge", "",
         r.problem.empty() ? 1.0 : 0.0},
    };
    if (!s.remote) return out;
    for (std::size_t op = 0; op < tiles::kS3OperationCount; ++op) {
      const std::string label = std::string("op=\"") + tiles::s3_operation_name(tiles::S3Operation(op)) + "\"";
      out.push_back({"zoomwarp_store_requests_total", op ? "" : "Requests made to the bucket (retries included), by operation.",
                     "counter", label, double(s.requests.requests[op])});
    }
    for (std::size_t op = 0; op < tiles::kS3OperationCount; ++op) {
      const std::string label = std::string("op=\"") + tiles::s3_operation_name(tiles::S3Operation(op)) + "\"";
      out.push_back({"zoomwarp_store_failures_total", op ? "" : "Bucket operations that failed after their retries, by operation.",
                     "counter", label, double(s.requests.failures[op])});
    }
    out.push_back({"zoomwarp_store_retries_total", "Bucket requests that were retries.", "counter", "", double(s.requests.retries)});
    out.push_back({"zoomwarp_store_bytes_total", "Bytes sent to and received from the bucket.", "counter",
                   R"(direction="received")", double(s.requests.bytes_received)});
    out.push_back({"zoomwarp_store_bytes_total", "", "counter", R"(direction="sent")", double(s.requests.bytes_sent)});
    out.push_back({"zoomwarp_store_cache_hits_total", "Reads of the bucket's bytes answered locally, by tier.", "counter",
                   R"(tier="memory")", double(s.cache.memory_hits)});
    out.push_back({"zoomwarp_store_cache_hits_total", "", "counter", R"(tier="disk")", double(s.cache.disk_hits)});
    out.push_back({"zoomwarp_store_cache_misses_total", "Reads of the bucket's bytes that went to the bucket.", "counter", "",
                   double(s.cache.misses)});
    out.push_back({"zoomwarp_store_cache_bytes", "Bytes of the bucket held locally, by tier.", "gauge", R"(tier="memory")",
                   double(s.cache.memory_bytes)});
    out.push_back({"zoomwarp_store_cache_bytes", "", "gauge", R"(tier="disk")", double(s.cache.disk_bytes)});
    out.push_back({"zoomwarp_store_cache_limit_bytes", "Bound of the local copy of the bucket's bytes, by tier.", "gauge",
                   R"(tier="memory")", double(s.cache.memory_limit)});
    out.push_back({"zoomwarp_store_cache_limit_bytes", "", "gauge", R"(tier="disk")", double(s.cache.disk_limit)});
    out.push_back({"zoomwarp_store_cache_evictions_total", "Files the disk tier removed to stay within its bound.", "counter",
                   "", double(s.cache.disk_evictions)});
    return out;
  }

  std::vector<net::io_context*> session_contexts() {
    std::vector<net::io_context*> all{&ioc};
    for (auto& c : more_contexts) all.push_back(c.get());
    return all;
  }

  tcp::endpoint endpoint() {
    boost::system::error_code ec;
    auto address = net::ip::make_address(state.options.host, ec);
    if (!ec) return {address, static_cast<unsigned short>(state.options.port)};
    tcp::resolver resolver(ioc);
    auto results = resolver.resolve(state.options.host, std::to_string(state.options.port), ec);
    if (ec || results.empty()) throw std::runtime_error("cannot resolve host '" + state.options.host + "'");
    return *results.begin();
  }

  // SIGHUP, for as long as the server runs: the operator rotated the keys (--keys).
  void await_reload() {
    reload_signals.async_wait([this](boost::system::error_code ec, int) {
      if (ec) return;
      if (state.options.on_reload) state.options.on_reload();
      else log_event("info", "SIGHUP ignored: nothing to reload without --keys");
      await_reload();
    });
  }

  void schedule_gc() {
    gc_timer.expires_after(state.options.gc_interval);
    gc_timer.async_wait([this](boost::system::error_code ec) {
      if (ec || state.draining) return;
      state.cpu.try_submit([this] {
        // A worker's time, as a request's: a hung store does not keep it (the next round goes on).
        const tiles::StoreDeadlineScope scope(std::chrono::steady_clock::now() + state.options.request_timeout);
        try {
          int removed = state.store.collect_garbage(state.options.gc_grace);
          if (removed > 0) log_event("info", "store garbage collected", {{"removed", removed}});
        } catch (const std::exception& e) {
          log_event("warning", "store garbage collection stopped", {{"error", e.what()}});
        }
      });
      schedule_gc();
    });
  }

  // SIGTERM: readiness fails at once; after drain_delay no new connections are taken, idle
  // keep-alive connections close, and the process exits once in-flight requests are answered, or
  // once drain_timeout has passed (then they are cancelled).
  void begin_drain(int signal) {
    if (state.draining.exchange(true)) return;
    log_event("info", "draining", {{"signal", signal}, {"delay_s", state.options.drain_delay.count()}});
    gc_timer.cancel();
    reload_signals.cancel();
    drain_timer.expires_after(state.options.drain_delay);
    drain_timer.async_wait([this](boost::system::error_code) {
      listener->stop();
      close_idle_sessions();
      drain_deadline = std::chrono::steady_clock::now() + state.options.drain_timeout;
      wait_for_sessions();
    });
  }

  std::vector<std::shared_ptr<Session>> open_sessions() {
    // Collect first, post after unlocking: a posted close may run at once on another I/O thread
    // and leave our copy as the last reference, and ~Session takes sessions_mu to unregister.
    std::vector<std::shared_ptr<Session>> open;
    std::lock_guard lock(state.sessions_mu);
    for (auto& [ptr, weak] : state.sessions)
      if (auto s = weak.lock()) open.push_back(std::move(s));
    return open;
  }

  void close_idle_sessions() {
    for (auto& s : open_sessions()) net::post(s->get_executor(), [s] { s->close_if_idle(); });
  }

  void cancel_requests() {
    for (auto& s : open_sessions()) net::post(s->get_executor(), [s] { s->cancel_request(); });
  }

  void wait_for_sessions() {
    std::size_t open;
    {
      std::lock_guard lock(state.sessions_mu);
      open = state.sessions.size();
    }
    // Also until the listener has closed: it may still be accepting connections already made.
    if (open == 0 && listener->closed()) return stop(open);
    if (std::chrono::steady_clock::now() > drain_deadline) {
      if (timed_out) return stop(open);
      // --drain-timeout is a promise to whoever sent the signal: stop the requests still running
      // (they are answered 503 if their worker reaches a step boundary in time) and leave soon.
      timed_out = true;
      log_event("warn", "drain timed out", {{"open_connections", open}});
      cancel_requests();
      drain_deadline = std::chrono::steady_clock::now() + kCancelGrace;
    }
    close_idle_sessions();  // connections that finished a request since
    drain_timer.expires_after(50ms);
    drain_timer.async_wait([this](boost::system::error_code) { wait_for_sessions(); });
  }

  void stop(std::size_t open) {
    log_event("info", "stopped", {{"open_connections", open}, {"connections_accepted", state.connections_accepted.load()},
                                  {"drain_timed_out", timed_out}});
    work.clear();
    ioc.stop();
    for (auto& c : more_contexts) c->stop();
  }

  // After the drain timeout, how long cancelled requests get to send their 503.
  static constexpr auto kCancelGrace = 500ms;

  ServerState state;
  net::io_context ioc;
  std::vector<std::unique_ptr<net::io_context>> more_contexts;  // one per further --io-threads
  net::signal_set signals;
  net::signal_set reload_signals;
  net::steady_timer drain_timer, gc_timer;
  std::chrono::steady_clock::time_point drain_deadline;
  bool timed_out = false;  // the drain timeout passed with connections open
  std::shared_ptr<Listener> listener;
  std::vector<net::executor_work_guard<net::io_context::executor_type>> work;  // one per context
};

HttpServer::HttpServer(HttpServerOptions options, tiles::Store& store, api::Router& router, WorkerPool& cpu,
                       WorkerPool& ingest, Metrics& metrics)
    : impl_(std::make_unique<Impl>(std::move(options), store, router, cpu, ingest, metrics)) {}

HttpServer::~HttpServer() = default;

int HttpServer::run() {
  Impl& m = *impl_;
  m.listener = std::make_shared<Listener>(m.ioc, m.session_contexts(), m.endpoint(), m.state);
  m.listener->run();
  for (net::io_context* c : m.session_contexts()) m.work.emplace_back(c->get_executor());
  m.signals.async_wait([&m](boost::system::error_code ec, int signal) {
    if (!ec) m.begin_drain(signal);
  });
  m.await_reload();
  m.schedule_gc();
  log_event("info", "listening",
            {{"host", m.state.options.host}, {"port", m.listener->port()}, {"io_threads", m.state.options.io_threads},
             {"store", m.state.store.root()}});
  std::vector<std::thread> threads;
  for (auto& c : m.more_contexts) threads.emplace_back([&c] { c->run(); });
  m.ioc.run();
  for (auto& t : threads) t.join();
  return 0;
}

}  // namespace zoomwarp::server
