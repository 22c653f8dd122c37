// Accepts connections and starts a Session for each, handing them to the session contexts in turn:
// each such io_context is run by one thread, so a session needs no strand (issue 16: a strand per
// connection on one io_context shared by all I/O threads cost a shared_ptr copy and a lock per
// handler, and the threads contended for its scheduler's lock — about a sixth of a cached tile).
// At --max-connections open connections, or when the process is out of file descriptors, it stops
// accepting for a short growing delay (10 ms doubling to 1 s) instead of spinning: the waiting
// connections stay in the kernel's listen backlog. Accept errors are logged at most once a second,
// with a count of the ones not logged.
// Thread-safety: run() and stop() may be called from any thread; everything else runs on the
// acceptor's strand.
#pragma once

#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "server/session.h"

namespace zoomwarp::server {

class Listener : public std::enable_shared_from_this<Listener> {
 public:
  // Binds and listens at once (on `ioc`); throws std::runtime_error if it cannot. Sessions go to
  // `session_contexts` round robin; each must be run by a single thread.
  Listener(boost::asio::io_context& ioc, std::vector<boost::asio::io_context*> session_contexts,
           boost::asio::ip::tcp::endpoint endpoint, ServerState& state);

  void run();   // starts accepting
  // Stops accepting: connections the kernel has already completed are accepted and answered,
  // then the listener closes (new attempts are refused). Running sessions go on.
  void stop();
  bool closed() const { return closed_; }
  unsigned short port() const;

 private:
  void accept();
  void pause();
  void close_now();
  void start_session(boost::asio::ip::tcp::socket socket);
  boost::asio::io_context& next_session_context();
  void log_rate_limited(const std::string& message, const std::string& error);

  std::vector<boost::asio::io_context*> session_contexts_;
  std::size_t next_context_ = 0;
  boost::asio::ip::tcp::acceptor acceptor_;
  boost::asio::steady_timer backoff_timer_;
  std::chrono::milliseconds backoff_{0};
  std::chrono::steady_clock::time_point last_log_{};
  std::uint64_t unlogged_ = 0;
  std::atomic<bool> closed_{false};
  ServerState& state_;
};

}  // namespace zoomwarp::server
