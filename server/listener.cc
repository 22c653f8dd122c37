#include "server/listener.h"

#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <algorithm>
#include <nlohmann/json.hpp>

#include "server/log.h"

namespace zoomwarp::server {

namespace net = boost::asio;
using tcp = net::ip::tcp;


Listener::Listener(net::io_context& ioc, std::vector<net::io_context*> session_contexts, tcp::endpoint endpoint,
                   ServerState& state)
    : session_contexts_(std::move(session_contexts)), acceptor_(net::make_strand(ioc)), backoff_timer_(acceptor_.get_executor()), state_(state) {
  boost::system::error_code ec;
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(net::socket_base::max_listen_connections, ec);
  if (ec)
    throw std::runtime_error("cannot listen on " + endpoint.address().to_string() + ":" +
                             std::to_string(endpoint.port()) + ": " + ec.message());
}

unsigned short Listener::port() const { return acceptor_.local_endpoint().port(); }

void Listener::run() {
  net::dispatch(acceptor_.get_executor(), [self = shared_from_this()] { self->accept(); });
}

void Listener::stop() {
  net::post(acceptor_.get_executor(), [self = shared_from_this()] { self->close_now(); });
}

void Listener::close_now() {
  // Closing a listening socket resets the connections the kernel has completed but we have not
  // accepted yet: their clients connected and sent a request, and would get a reset. So take
  // them first (non-blocking, until none is left) and answer them like any other. (Handshakes
  // that complete in the microseconds between the last accept and the close are still reset by
  // the kernel: every server that closes its listener has that window.)
  boost::system::error_code ec;
  acceptor_.non_blocking(true, ec);
  while (!ec && acceptor_.is_open()) {
    tcp::socket socket(next_session_context());
    acceptor_.accept(socket, ec);
    if (!ec) {
      ++state_.connections_accepted;
      start_session(std::move(socket));
    }
  }
  acceptor_.close(ec);
  backoff_timer_.cancel();
  closed_ = true;
}

net::io_context& Listener::next_session_context() {
  net::io_context& ioc = *session_contexts_[next_context_];
  next_context_ = (next_context_ + 1) % session_contexts_.size();
  return ioc;
}

void Listener::start_session(tcp::socket socket) {
  boost::system::error_code ec;
  socket.set_option(tcp::no_delay(true), ec);
  std::make_shared<Session>(std::move(socket), state_)->start();
}

namespace {
// Errors that say the process or the system is out of something a connection needs: accepting
// again at once would fail again at once.
bool out_of_resources(boost::system::error_code ec) {
  return ec == net::error::no_descriptors || ec == boost::system::errc::too_many_files_open_in_system ||
         ec == net::error::no_buffer_space || ec == net::error::no_memory;
}
}  // namespace

void Listener::accept() {
  if (state_.open_connections.load() >= state_.options.max_connections) {
    log_rate_limited("connection limit reached", std::to_string(state_.options.max_connections) + " open");
    return pause();
  }
  acceptor_.async_accept(next_session_context(), [self = shared_from_this()](boost::system::error_code ec,
                                                                            tcp::socket socket) {
    if (ec == net::error::operation_aborted) return;
    // A connection this accept took just before stop() closed the acceptor is answered too.
    if (!ec) {
      ++self->state_.connections_accepted;
      self->backoff_ = {};
      self->start_session(std::move(socket));
    }
    if (!self->acceptor_.is_open()) return;
    if (ec) self->log_rate_limited("accept failed", ec.message());
    if (out_of_resources(ec)) return self->pause();
    self->accept();
  });
}

void Listener::pause() {
  using namespace std::chrono_literals;
  backoff_ = std::clamp(backoff_ * 2, 10ms, std::chrono::milliseconds(1s));
  backoff_timer_.expires_after(backoff_);
  backoff_timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
    if (!ec && self->acceptor_.is_open()) self->accept();
  });
}

// A flood of failing accepts (e.g. at the file descriptor limit) must not flood the log too.
void Listener::log_rate_limited(const std::string& message, const std::string& error) {
  const auto now = std::chrono::steady_clock::now();
  if (now - last_log_ < std::chrono::seconds(1)) {
    ++unlogged_;
    return;
  }
  log_event("warn", message, {{"error", error}, {"not_logged_since_last", unlogged_}});
  last_log_ = now;
  unlogged_ = 0;
}

}  // namespace zoomwarp::server
