// One HTTP connection: read a request header, then its body (uploads stream to a file), answer it
// on this thread or on a worker, write the response, repeat while keep-alive holds.
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
#include <vector>

#include "api/router.h"
#include "server/http_server_options.h"
#include "server/metrics.h"
#include "server/upload_admission.h"
#include "server/worker_pool.h"
#include "server/store_monitor.h"
#include "tiles/store.h"
#include "warp/core/stop_token.h"

namespace zoomwarp::server {

class Session;

// What the listener and every session share. Thread-safety: the references and options are fixed
// after construction; the atomics and `uploads` may be used from any thread, `sessions` under
// `sessions_mu`.
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
  void read_header();
  void read_header_bytes();
  void on_header(boost::beast::error_code ec);
  void read_body();
  void on_body(boost::beast::error_code ec);
  void answer();
  void submit(WorkerPool& pool);
  void watch_peer();
  void on_peer_read(boost::beast::error_code ec, std::size_t bytes);
  void send(api::Response res);
  void on_write(bool close, boost::beast::error_code ec);
  void next(bool close);  // after a response: read the next request, or close
  void linger();
  void discard_upload();
  std::optional<api::Response> admit_upload();
  std::optional<api::Response> rate_limit_upload(std::uint64_t bytes);
  void read_upload();
  void on_upload_chunk(boost::beast::error_code ec);
  std::optional<api::Response> refuse_upload_head(bool whole_body) const;
  std::optional<api::Response> open_upload_file();
  void finish_upload();

  boost::beast::tcp_stream stream_;
  boost::beast::flat_buffer buffer_;
  ServerState& state_;
  std::string remote_;          // "ADDRESS:PORT", for logs
  std::string remote_address_;  // "ADDRESS", for api::Request::client_address

  std::optional<boost::beast::http::request_parser<boost::beast::http::empty_body>> header_parser_;
  std::optional<boost::beast::http::request_parser<boost::beast::http::string_body>> string_parser_;
  // An upload is read through a buffer_body in chunks: its first chunk is checked (format, size)
  // before anything is written, then each chunk is appended to the staging file.
  std::optional<boost::beast::http::request_parser<boost::beast::http::buffer_body>> upload_parser_;
  std::vector<std::uint8_t> upload_chunk_;
  std::size_t upload_filled_ = 0;  // bytes of upload_chunk_ holding body not yet written
  boost::beast::file upload_file_;
  UploadAdmission::Slot upload_slot_;
  boost::beast::http::response<boost::beast::http::empty_body> continue_;

  api::Request req_;
  std::string target_;
  std::string preflight_method_;  // Access-Control-Request-Method of an OPTIONS request
  unsigned version_ = 11;
  bool keep_alive_ = true;
  bool idle_ = true;
  bool fresh_ = true;  // no request read yet
  std::chrono::steady_clock::time_point accepted_ = std::chrono::steady_clock::now();
  std::string upload_dir_;
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
