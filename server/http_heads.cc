#include "server/http_heads.h"

#include <boost/asio/ip/address.hpp>
#include <boost/beast/core/string.hpp>
#include <boost/beast/http/status.hpp>
#include <cstring>

#include "api/errors.h"

namespace zoomwarp::server {

namespace beast = boost::beast;
namespace http = beast::http;

namespace {
// The client's address behind a proxy: the last X-Forwarded-For entry, the one the proxy in front
// of us appended (earlier ones the client may have made up). `peer` if there is none or it is not
// an IP address.
std::string forwarded_client(std::string_view forwarded_for, const std::string& peer) {
  const std::size_t comma = forwarded_for.rfind(',');
  std::string last(comma == std::string_view::npos ? forwarded_for : forwarded_for.substr(comma + 1));
  last.erase(0, last.find_first_not_of(" \t"));
  last.erase(last.find_last_not_of(" \t") + 1);
  boost::system::error_code ec;
  const auto address = boost::asio::ip::make_address(last, ec);
  return ec ? peer : address.to_string();
}

// Appends "Name: value\r\n"; values with line breaks are dropped rather than let split the head.
void append_field(std::string& out, std::string_view name, std::string_view value) {
  if (std::memchr(value.data(), '\r', value.size()) || std::memchr(value.data(), '\n', value.size())) return;
  out.append(name).append(": ").append(value).append("\r\n");
}
}  // namespace

api::Request request_from_header(const http::request_header<>& h, const std::string& peer, bool trust_forwarded_for) {
  api::Request req;
  req.method = std::string(h.method_string());
  const std::string_view target = h.target();
  const std::size_t q = target.find('?');
  req.path = std::string(target.substr(0, q));
  req.query = q == std::string_view::npos ? "" : std::string(target.substr(q + 1));
  req.host = std::string(h[http::field::host]);
  req.forwarded_proto = std::string(h["X-Forwarded-Proto"]);
  req.if_none_match = std::string(h[http::field::if_none_match]);
  req.if_match = std::string(h[http::field::if_match]);
  req.accept = std::string(h[http::field::accept]);
  req.authorization = std::string(h[http::field::authorization]);
  req.origin = std::string(h[http::field::origin]);
  req.client_address = trust_forwarded_for ? forwarded_client(h["X-Forwarded-For"], peer) : peer;
  return req;
}

// A body whose last coding is not chunked has no knowable length (400 and close, RFC 9112 §6.3);
// other codings before it we cannot decode (501, and close too: the body is not read). Beast would
// read the former to the end of the stream and hand us the latter still compressed.
std::optional<api::Response> refuse_transfer_encoding(const http::request_header<>& h) {
  const auto te = h[http::field::transfer_encoding];
  if (te.empty() || (beast::iequals(te, "chunked") && h.count(http::field::transfer_encoding) == 1)) return std::nullopt;
  const std::size_t comma = te.rfind(',');
  std::string_view last = comma == std::string_view::npos ? te : te.substr(comma + 1);
  while (!last.empty() && (last.front() == ' ' || last.front() == '\t')) last.remove_prefix(1);
  if (!beast::iequals(last, "chunked") || h.count(http::field::transfer_encoding) > 1)
    return api::error_response(400, "bad_transfer_encoding", "Transfer-Encoding must be chunked (or absent), not '" + std::string(te) + "'");
  return api::error_response(501, "unsupported_transfer_encoding", "the only transfer coding understood is chunked, not '" + std::string(te) + "'");
}

bool bodiless_status(int status) { return status < 200 || status == 204 || status == 304; }

void append_response_head(std::string& out, const api::Response& r, unsigned version, const HeaderList& cors,
                          bool keep_alive) {
  out.append(version == 10 ? "HTTP/1.0 " : "HTTP/1.1 ")
      .append(std::to_string(r.status))
      .append(" ")
      .append(http::obsolete_reason(http::int_to_status(unsigned(r.status))))
      .append("\r\n");
  append_field(out, "Server", "zoomwarp");
  if (!r.content_type.empty()) append_field(out, "Content-Type", r.content_type);
  for (const auto& [name, value] : r.headers) append_field(out, name, value);
  for (const auto& [name, value] : cors) append_field(out, name, value);
  if (!bodiless_status(r.status)) append_field(out, "Content-Length", std::to_string(r.body ? r.body->size() : 0));
  if (!keep_alive) append_field(out, "Connection", "close");
  else if (version == 10) append_field(out, "Connection", "keep-alive");
  out.append("\r\n");
}

}  // namespace zoomwarp::server
