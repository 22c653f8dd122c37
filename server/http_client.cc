#include "server/http_client.h"

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <optional>

namespace zoomwarp::server {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;

namespace {
// Beast's default is 8 MB; a 4096×4096 PNG viewport can be several times that.
constexpr std::uint64_t kBodyLimit = 256ull << 20;
}  // namespace

// Every network step is an async operation run to completion on this client's own io_context,
// not one of Beast's blocking calls: only async operations honour tcp_stream's time limit, and a
// stalled server must cost an error, not a hung client.
struct HttpClient::Impl {
  std::string host, port;
  std::chrono::milliseconds timeout;
  net::io_context ioc;
  std::optional<tcp::resolver::results_type> endpoints;
  std::optional<beast::tcp_stream> stream;
  beast::flat_buffer buffer;

  void run() {
    ioc.restart();
    ioc.run();
  }

  [[noreturn]] void fail(const std::string& what) {
    stream.reset();
    buffer.clear();
    throw HttpClientError(what);
  }

  void connect() {
    if (!endpoints) {
      beast::error_code ec;
      auto results = tcp::resolver(ioc).resolve(host, port, ec);  // getaddrinfo has its own time limits
      if (ec) fail("cannot resolve " + host + ": " + ec.message());
      endpoints = std::move(results);
    }
    stream.emplace(ioc);
    stream->expires_after(timeout);
    beast::error_code ec;
    stream->async_connect(*endpoints, [&](beast::error_code e, const tcp::endpoint&) { ec = e; });
    run();
    if (ec) fail("cannot connect to " + host + ":" + port + ": " + ec.message());
  }

  HttpClientResponse get(const std::string& target) {
    if (!stream) connect();
    http::request<http::empty_body> req{http::verb::get, target, 11};
    req.set(http::field::host, host + ":" + port);
    req.set(http::field::user_agent, "zoomwarp-replay");
    http::response_parser<http::string_body> parser;
    parser.body_limit(kBodyLimit);
    beast::error_code ec;
    stream->expires_after(timeout);  // one limit for the whole exchange
    http::async_write(*stream, req, [&](beast::error_code e, std::size_t) {
      if (e) ec = e;
      else http::async_read(*stream, buffer, parser, [&](beast::error_code e, std::size_t) { ec = e; });
    });
    run();
    if (ec) fail("GET " + target + ": " + ec.message());
    auto& res = parser.get();
    if (!res.keep_alive()) stream.reset();  // the server closes it: reconnect next time
    return {int(res.result_int()), std::move(res.body())};
  }
};

HttpClient::HttpClient(std::string host, std::string port, std::chrono::milliseconds timeout)
    : impl_(std::make_unique<Impl>()) {
  impl_->host = std::move(host);
  impl_->port = std::move(port);
  impl_->timeout = timeout;
}

HttpClient::~HttpClient() = default;

HttpClientResponse HttpClient::get(const std::string& target) { return impl_->get(target); }

}  // namespace zoomwarp::server
