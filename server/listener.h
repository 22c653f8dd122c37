// Accepts connections and starts a Session for each, each on its own strand.
#pragma once

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
  void stop();  // stops accepting; running sessions go on
  unsigned short port() const;

 private:
  void accept();

  boost::asio::io_context& ioc_;
  boost::asio::ip::tcp::acceptor acceptor_;
  ServerState& state_;
};

}  // namespace zoomwarp::server
