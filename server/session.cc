#include "server/session.h"

#include <boost/asio/dispatch.hpp>
#include <boost/asio/write.hpp>
#include <boost/asio/post.hpp>
#include <array>
#include <limits>
#include <nlohmann/json.hpp>

#include "api/errors.h"
#include "server/http_heads.h"
#include "server/log.h"
#include "server/ops.h"
#include "tiles/store_deadline.h"
#include "tiles/store_errors.h"

namespace zoomwarp::server {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;

namespace {
constexpr std::size_t kHeaderLimit = 16 * 1024;
constexpr std::size_t kFirstReadBytes = 8 * 1024;
constexpr auto kWriteTimeout = std::chrono::seconds(60);
constexpr auto kLingerTimeout = std::chrono::seconds(2);
constexpr auto kFreshConnectionGrace = std::chrono::seconds(1);

// Errors that mean the client went away or stalled: there is nobody to answer.
bool client_gone(beast::error_code ec) {
  return ec == beast::error::timeout || ec == net::error::eof || ec == http::error::end_of_stream ||
         ec == http::error::partial_message || ec == net::error::connection_reset ||
         ec == net::error::operation_aborted || ec == net::error::broken_pipe;
}
}  // namespace

Session::Session(net::ip::tcp::socket&& socket, ServerState& state)
    : stream_(std::move(socket)), state_(state) {
  ++state_.open_connections;
  beast::error_code ec;
  auto ep = stream_.socket().remote_endpoint(ec);
  if (!ec) {
    remote_address_ = ep.address().to_string();
    remote_ = remote_address_ + ":" + std::to_string(ep.port());
  }
}

Session::~Session() {
  upload_.reset();  // first: a drain that finds no session left may end the process at once
  --state_.open_connections;
  std::lock_guard lock(state_.sessions_mu);
  state_.sessions.erase(this);
}

void Session::start() {
  {
    std::lock_guard lock(state_.sessions_mu);
    state_.sessions.emplace(this, weak_from_this());
  }
  net::dispatch(stream_.get_executor(), [self = shared_from_this()] { self->read_header(); });
}

void Session::close_if_idle() {
  if (!idle_ || buffer_.size() > 0) return;
  // A connection accepted a moment ago has its first request on the way: closing it now would
  // reset that request. It gets a short grace (the drain calls this again every 50 ms).
  if (fresh_ && std::chrono::steady_clock::now() - accepted_ < kFreshConnectionGrace) return;
  beast::error_code ec;
  stream_.socket().shutdown(net::ip::tcp::socket::shutdown_both, ec);
  stream_.close();
}

void Session::read_header() {
  // Also while draining: a new connection accepted during the drain delay, or one whose last
  // response still said keep-alive, is owed an answer to the request it is sending (which will say
  // "Connection: close"). Dropping it here reset those clients; close_if_idle() ends the
  // connections that stay idle once the listener has closed.
  idle_ = true;
  header_parser_.emplace();
  header_parser_->header_limit(kHeaderLimit);
  // The body's limit depends on the route and is set once the header is read. (Not boost::none:
  // Beast 1.74 compares the length against an empty optional and always fails.)
  header_parser_->body_limit(std::numeric_limits<std::uint64_t>::max());
  if (buffer_.size() > 0) return read_header_bytes();  // pipelined: the next request is here
  // Waiting for a request is bounded by the idle timeout; once its first bytes are here, the whole
  // header must follow within the header timeout, so a client dripping a header is dropped.
  stream_.expires_after(state_.options.idle_timeout);
  stream_.async_read_some(buffer_.prepare(kFirstReadBytes), [self = shared_from_this()](beast::error_code ec, std::size_t n) {
    self->buffer_.commit(n);
    if (ec) return self->on_header(ec);
    self->read_header_bytes();
  });
}

void Session::read_header_bytes() {
  // A request's header nearly always arrives whole in one read: parsed here, it costs no timer and
  // no composed read (issue 16, cached tiles). The rest of a header that is not all here is read
  // under the header timeout.
  beast::error_code ec;
  buffer_.consume(header_parser_->put(buffer_.data(), ec));
  if (ec != http::error::need_more) return on_header(ec);
  stream_.expires_after(state_.options.header_timeout);
  http::async_read_header(stream_, buffer_, *header_parser_,
                          [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_header(ec); });
}

void Session::on_header(beast::error_code ec) {
  if (ec) {
    if (client_gone(ec)) return;  // closed or timed out between requests: nothing to answer
    idle_ = false;
    started_ = std::chrono::steady_clock::now();
    req_ = api::Request{};
    target_.clear();
    keep_alive_ = false;  // after a malformed message the stream cannot be trusted
    if (ec == http::error::header_limit)
      return send(api::error_response(431, "header_too_large", "request headers are over 16 KiB"));
    return send(api::error_response(400, "bad_request", "malformed HTTP request: " + ec.message()));
  }
  idle_ = false;
  fresh_ = false;
  started_ = std::chrono::steady_clock::now();
  auto& h = header_parser_->get();
  version_ = h.version();
  keep_alive_ = h.keep_alive();
  target_ = std::string(h.target());
  req_ = request_from_header(h, remote_address_, state_.options.trust_forwarded_for);
  preflight_method_ = std::string(h[http::field::access_control_request_method]);
  const bool expect_continue = beast::iequals(h[http::field::expect], "100-continue");
  const bool upload = api::Router::is_upload(req_.method, req_.path);
  std::optional<api::Response> refusal = refuse_transfer_encoding(h);
  if (!refusal && !upload && header_parser_->is_done()) {  // no body (most GETs): answer straight away
    header_parser_.reset();
    return answer();
  }
  if (!refusal) refusal = upload ? start_upload() : start_body();
  if (refusal) {
    // The body is not read (or its length is unknown): the rest of the stream cannot be trusted.
    keep_alive_ = false;
    return send(std::move(*refusal));
  }
  header_parser_.reset();

  if (expect_continue) {
    continue_ = {http::status::continue_, version_};
    return http::async_write(stream_, continue_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (!ec) self->read_body();
    });
  }
  read_body();
}

// An upload is refused before a byte of its body is read for its declared size, its credentials
// or its admission (upload_staging.h); admitted, its body is read in pieces (read_upload()).
std::optional<api::Response> Session::start_upload() {
  const auto length = header_parser_->content_length();
  if (length && *length > state_.options.max_upload_bytes)
    return api::error_response(413, "upload_too_large",
                               "uploads are limited to " + std::to_string(state_.options.max_upload_bytes) + " bytes");
  if (auto refusal = state_.router.authorize(req_)) return refusal;
  upload_.emplace(state_.upload_context);
  if (auto refusal = upload_->admit(req_, length ? std::optional(*length) : std::nullopt)) return refusal;
  upload_parser_.emplace(std::move(*header_parser_));
  upload_parser_->body_limit(state_.options.max_upload_bytes);
  return std::nullopt;
}

// Beast checks a Content-Length against the body limit while parsing the header, which was done
// under no limit; so a declared length is checked here (chunked bodies by the parser).
std::optional<api::Response> Session::start_body() {
  const auto length = header_parser_->content_length();
  if (length && *length > state_.options.max_body_bytes)
    return api::error_response(
        413, "body_too_large", "request bodies are limited to " + std::to_string(state_.options.max_body_bytes) + " bytes");
  string_parser_.emplace(std::move(*header_parser_));
  string_parser_->body_limit(state_.options.max_body_bytes);
  return std::nullopt;
}

void Session::read_body() {
  if (upload_parser_) return read_upload();
  stream_.expires_after(state_.options.body_timeout);  // JSON bodies are small: one timeout for all
  auto done = [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_body(ec); };
  http::async_read(stream_, buffer_, *string_parser_, std::move(done));
}

void Session::on_body(beast::error_code ec) {
  if (ec == http::error::body_limit) {
    keep_alive_ = false;
    return send(api::error_response(413, "body_too_large", "the request body is over the limit"));
  }
  if (client_gone(ec)) return;
  if (ec) {
    keep_alive_ = false;
    return send(api::error_response(400, "bad_request", "malformed HTTP request: " + ec.message()));
  }
  req_.body = std::move(string_parser_->get().body());
  string_parser_.reset();
  answer();
}

// Reads the next piece of the upload's body into its staging's space(); the body timeout is the
// longest pause allowed between two pieces (a stalled upload is dropped, its staging folder removed).
void Session::read_upload() {
  const std::span<std::uint8_t> space = upload_->space();
  auto& body = upload_parser_->get().body();
  body.data = space.data();
  body.size = space.size();
  body.more = true;
  if (upload_parser_->is_done()) return on_upload_chunk({});  // no body at all (Content-Length: 0)
  stream_.expires_after(state_.options.body_timeout);
  http::async_read_some(stream_, buffer_, *upload_parser_,
                        [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_upload_chunk(ec); });
}

// Hands what the read brought to the staging (upload_staging.h), which may refuse the upload.
void Session::on_upload_chunk(beast::error_code ec) {
  if (ec == http::error::need_buffer) ec = {};  // the space given is full: not an error
  if (ec) return on_body(ec);
  const std::size_t n = upload_->space().size() - upload_parser_->get().body().size;
  const bool done = upload_parser_->is_done();
  std::optional<api::Response> refusal = upload_->add(n, done);
  if (!refusal && done) refusal = upload_->finish();
  if (refusal) {
    keep_alive_ = false;  // the rest of the body is not read
    return send(std::move(*refusal));
  }
  if (!done) return read_upload();
  upload_parser_.reset();
  req_.body_file = upload_->file();
  answer();
}

void Session::answer() {
  if (req_.method == "OPTIONS") {  // CORS preflight (server/cors.h)
    api::Response r;
    r.status = 204;
    r.route = "preflight";
    r.headers = state_.options.cors.preflight(req_.origin, preflight_method_);
    return send(std::move(r));
  }
  try {
    if (auto r = answer_ops(req_, OpsContext{state_.store_monitor, state_.metrics, state_.draining, state_.options.face_detection, state_.router.config().access})) return send(std::move(*r));
    if (auto r = state_.router.try_answer_now(req_)) return send(std::move(*r));
  } catch (const std::exception& e) {
    return send(api::internal_error_response(e.what()));
  }
  submit(api::Router::is_upload(req_.method, req_.path) ? state_.ingest : state_.cpu);
}

// Hands the request to a worker. A CPU request gets its deadline here (uploads are bounded by their
// size instead: ingesting 500 MB takes as long as it takes).
void Session::submit(WorkerPool& pool) {
  stream_.expires_never();  // a slow computation is not the client's fault
  const bool bounded = &pool == &state_.cpu;
  const auto deadline = bounded ? std::chrono::steady_clock::now() + state_.options.request_timeout
                                : std::chrono::steady_clock::time_point::max();
  stop_ = bounded ? std::make_shared<warp::StopToken>(deadline) : std::make_shared<warp::StopToken>();
  req_.stop = stop_.get();
  const bool queued = pool.try_submit([self = shared_from_this(), deadline] {
    api::Response r;
    try {
      // The store's requests end by the request's deadline too (a hung bucket: 504, not a worker
      // held for the store's own budget).
      const tiles::StoreDeadlineScope store_deadline(deadline);
      r = self->state_.router.handle(self->req_);
    } catch (const warp::Stopped& stopped) {
      r = api::stopped_response(stopped.reason());
    } catch (const tiles::StoreUnavailable& e) {
      r = api::store_unavailable_response(e);
    } catch (const std::exception& e) {
      r = api::internal_error_response(e.what());
    }
    net::post(self->stream_.get_executor(), [self, r = std::move(r)]() mutable { self->send(std::move(r)); });
  });
  if (!queued) {
    api::Response r = api::error_response(503, "overloaded", "the server is busy; retry shortly");
    r.set_header("Retry-After", "1");
    r.route = "overloaded";
    return send(std::move(r));
  }
  with_worker_ = true;
  watch_peer();
}

void Session::cancel_request() {
  if (with_worker_) stop_->cancel();
}

// While a worker has the request, a read on the socket tells whether the client is still there:
// end of stream or an error cancels the request's token, and its worker stops at the next step
// (the render and solver loops check it). Bytes that arrive are the client's next, pipelined
// request: they stay in the buffer for read_header() (up to a header's worth; then no more watching).
void Session::watch_peer() {
  if (buffer_.size() >= kHeaderLimit) return;
  watching_ = true;
  stream_.async_read_some(buffer_.prepare(kHeaderLimit - buffer_.size()),
                          [self = shared_from_this()](beast::error_code ec, std::size_t n) { self->on_peer_read(ec, n); });
}

void Session::on_peer_read(beast::error_code ec, std::size_t bytes) {
  watching_ = false;
  buffer_.commit(bytes);
  if (ec && ec != net::error::operation_aborted) {
    if (with_worker_) stop_->cancel();
    keep_alive_ = false;  // nobody to read a next request from
  } else if (!ec && with_worker_) {
    return watch_peer();
  }
  const AfterWatch after = std::exchange(after_watch_, AfterWatch::kNothing);
  if (after != AfterWatch::kNothing) next(after == AfterWatch::kClose);
}

// The head is written by hand and sent with the body in one gather write (http_heads.h).
void Session::send(api::Response r) {
  // An upload's parser, staging folder and slot end before the client hears back, so it never
  // sees the upload's leftovers.
  upload_parser_.reset();
  upload_.reset();
  with_worker_ = false;
  if (watching_) stream_.cancel();  // the watch's handler ends it; on_write waits for that
  current_ = std::move(r);
  if (current_.route.empty()) current_.route = "error";
  const bool send_body = !bodiless_status(current_.status) && req_.method != "HEAD" && current_.body &&
                         !current_.body->empty();
  const bool keep = keep_alive_ && !state_.draining.load();
  head_.clear();
  append_response_head(head_, current_, version_,
                       req_.method == "OPTIONS" ? HeaderList{}  // a preflight's answer has its own (answer())
                                                : state_.options.cors.response(req_.method, req_.origin),
                       keep);

  const std::array<net::const_buffer, 2> buffers = {
      net::buffer(head_), send_body ? net::buffer(*current_.body) : net::const_buffer()};
  stream_.expires_after(kWriteTimeout);
  net::async_write(stream_, buffers, [self = shared_from_this(), keep](beast::error_code ec, std::size_t) {
    self->on_write(!keep, ec);
  });
}

void Session::on_write(bool close, beast::error_code ec) {
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  state_.metrics.observe_request(current_.route, current_.status, seconds);
  if (!current_.failure.empty()) state_.metrics.observe_failure(current_.route, current_.failure);
  if (current_.failure == "deadline" || current_.failure == "cancelled")
    log_event("warn", "request stopped", {{"method", req_.method}, {"target", target_}, {"route", current_.route},
                                          {"reason", current_.failure}, {"ms", std::round(seconds * 1e5) / 100}});
  if (!current_.log_detail.empty())
    log_event("error", "request failed", {{"method", req_.method}, {"target", target_}, {"route", current_.route},
                                          {"status", current_.status}, {"error", current_.log_detail}});
  if (state_.options.log_requests) {
    nlohmann::json fields = {{"method", req_.method},    {"target", target_},
                             {"status", current_.status}, {"route", current_.route},
                             {"bytes", current_.body ? current_.body->size() : 0},
                             {"ms", std::round(seconds * 1e5) / 100}, {"remote", remote_}};
    if (!current_.cache.empty()) fields["cache"] = current_.cache;
    if (ec) fields["write_error"] = ec.message();
    log_event("info", "request", fields);
  }
  current_ = {};
  if (ec) return;
  if (watching_) {
    // One read at a time: the next step waits for the peer watch, which send() cancelled, to end.
    after_watch_ = close ? AfterWatch::kClose : AfterWatch::kReadNext;
    return;
  }
  next(close);
}

void Session::next(bool close) {
  if (close) {
    beast::error_code ignored;
    stream_.socket().shutdown(net::ip::tcp::socket::shutdown_send, ignored);
    stream_.expires_after(kLingerTimeout);  // one deadline for the whole lingering
    return linger();
  }
  read_header();
}

// Closing a socket with unread input makes the kernel send a reset, which can destroy the response
// still in flight (e.g. a 413 to an upload whose body we refused to read). So after shutting down
// our side we read and drop what the client still sends, for a short while, as nginx does.
void Session::linger() {
  buffer_.consume(buffer_.size());
  stream_.async_read_some(buffer_.prepare(64 * 1024), [self = shared_from_this()](beast::error_code ec, std::size_t) {
    if (!ec) self->linger();
  });
}

}  // namespace zoomwarp::server
