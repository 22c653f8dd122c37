// Accepts connections and starts a Session for each, each on its own strand.
#pragma once

#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <memory>

#include "server/session.h"

namespace zoomwarp::server {

class Listener : public std::enable_shared_from_this<Listener> {
 public:
  // Binds and listens at once; throws std::runtime_error if it cannot.
  Listener(boost::asio::io_context& ioc, boost::asio::ip::tcp::endpoint endpoint, ServerState& state);

  void run();   // starts accepting
  // Stops accepting: connections the kernel has already completed are accepted and answered,
  // then the listener closes (new attempts are refused). Running sessions go on.
  void stop();
  bool closed() const { return closed_; }
  unsigned short port() const;

 private:
  void accept();
  void close_now();
  void start_session(boost::asio::ip::tcp::socket socket);

  boost::asio::io_context& ioc_;
  boost::asio::ip::tcp::acceptor acceptor_;
  std::atomic<bool> closed_{false};
  ServerState& state_;
};

}  // namespace zoomwarp::server
