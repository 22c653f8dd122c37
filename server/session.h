// One HTTP connection: read a request header, then its body, answer it on this thread or on a
// worker, write the response, repeat while keep-alive holds. The session is the socket's side of
// it: the Beast reads and writes, timeouts, keep-alive and framing errors. What a head means in
// api terms is http_heads.h's; an upload's admission and staging file are UploadStaging's
// (upload_staging.h), to which the session hands the body's pieces as they arrive.
//
// A request computed on the CPU workers carries a StopToken (api::Request::stop) whose deadline is
// --request-timeout after the request was read, queue time included. While it is with a worker the
// session keeps reading the socket: the client closing the connection cancels the token (bytes that
// arrive meanwhile are its next, pipelined request and are kept).
//
// Threads: a Session runs on its io_context, which one thread runs (server/listener.h): an implicit
// strand. Every member function but start() must be called there (post to get_executor()).
// ServerState is shared by all sessions and the listener: its references are to thread-safe
// objects, its atomics and `sessions` (under sessions_mu) are the only state it has.
#pragma once

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include "api/router.h"
#include "server/http_server_options.h"
#include "server/metrics.h"
#include "server/store_monitor.h"
#include "server/upload_admission.h"
#include "server/upload_staging.h"
#include "server/worker_pool.h"
#include "tiles/store.h"
#include "warp/core/stop_token.h"

namespace zoomwarp::server {

class Session;

// What the listener and every session share. Thread-safety: the references and options are fixed
// after construction; the atomics, `uploads` and `upload_limits` may be used from any thread,
// `sessions` under `sessions_mu`.
struct ServerState {
  ServerState(HttpServerOptions o, tiles::Store& s, api::Router& r, WorkerPool& c, WorkerPool& i, Metrics& m)
      : options(std::move(o)),
        store(s),
        router(r),
        cpu(c),
        ingest(i),
        metrics(m),
        store_monitor(s, options.store_check_interval, options.store_check_timeout) {}

  HttpServerOptions options;
  tiles::Store& store;
  api::Router& router;
  WorkerPool& cpu;
  WorkerPool& ingest;
  Metrics& metrics;
  StoreMonitor store_monitor;  // readiness and the image count, without waiting for the store
  std::atomic<bool> draining{false};
  std::atomic<std::uint64_t> connections_accepted{0};  // logged when the server stops
  std::atomic<std::size_t> open_connections{0};        // sessions alive, against max_connections
  UploadAdmission uploads{options.upload_slots, options.max_staging_bytes};
  api::RateLimits upload_limits{options.upload_limits};
  UploadContext upload_context{store, uploads, upload_limits, metrics, router.config().access.keys,
                               router.config().ingest.limits, options.max_upload_bytes};

  std::mutex sessions_mu;
  std::unordered_map<Session*, std::weak_ptr<Session>> sessions;  // for draining
};

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(boost::asio::ip::tcp::socket&& socket, ServerState& state);
  ~Session();

  void start();
  // Drain: closes the connection if it is waiting for a new request (a new connection only once
  // it has had a second to send its first). Runs on the session's executor.
  void close_if_idle();
  // Drain timeout: cancels the request being computed, if any, so its worker stops at the next
  // step and it is answered 503. Runs on the session's executor.
  void cancel_request();
  auto get_executor() { return stream_.get_executor(); }

 private:
  // Reading a request: its header, then its body (or the refusal to read it).
  void read_header();
  void read_header_bytes();
  void on_header(boost::beast::error_code ec);
  std::optional<api::Response> start_upload();
  std::optional<api::Response> start_body();
  void read_body();
  void on_body(boost::beast::error_code ec);
  void read_upload();
  void on_upload_chunk(boost::beast::error_code ec);
  // Answering it, here or on a worker while the socket is watched for the client leaving.
  void answer();
  void submit(WorkerPool& pool);
  void watch_peer();
  void on_peer_read(boost::beast::error_code ec, std::size_t bytes);
  // Writing the response, then reading the next request or closing.
  void send(api::Response r);
  void on_write(bool close, boost::beast::error_code ec);
  void next(bool close);
  void linger();

  boost::beast::tcp_stream stream_;
  boost::beast::flat_buffer buffer_;
  ServerState& state_;
  std::string remote_;          // "ADDRESS:PORT", for logs
  std::string remote_address_;  // "ADDRESS", for api::Request::client_address

  std::optional<boost::beast::http::request_parser<boost::beast::http::empty_body>> header_parser_;
  std::optional<boost::beast::http::request_parser<boost::beast::http::string_body>> string_parser_;
  // An upload is read through a buffer_body in pieces, into the space its staging gives.
  std::optional<boost::beast::http::request_parser<boost::beast::http::buffer_body>> upload_parser_;
  std::optional<UploadStaging> upload_;  // from the upload's admission until it is answered
  boost::beast::http::response<boost::beast::http::empty_body> continue_;

  api::Request req_;
  std::string target_;
  std::string preflight_method_;  // Access-Control-Request-Method of an OPTIONS request
  unsigned version_ = 11;
  bool keep_alive_ = true;
  bool idle_ = true;
  bool fresh_ = true;  // no request read yet
  std::chrono::steady_clock::time_point accepted_ = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point started_;
  std::shared_ptr<warp::StopToken> stop_;  // of the request with a worker, shared with its job
  bool with_worker_ = false;      // the request is queued or running in a worker pool
  bool watching_ = false;         // watch_peer()'s read is pending
  enum class AfterWatch { kNothing, kReadNext, kClose };
  AfterWatch after_watch_ = AfterWatch::kNothing;  // the response is written; what to do once the watch ends

  api::Response current_;  // the response being written (owns the body bytes)
  std::string head_;       // its status line and header fields
};

}  // namespace zoomwarp::server
