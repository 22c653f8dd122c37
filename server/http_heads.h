// HTTP heads in the api layer's terms, for the session (session.h): a request's header read into
// an api::Request, the transfer codings refused before its body is read, and a response's head
// written from an api::Response. Pure functions: any thread.
#pragma once

#include <boost/beast/http/message.hpp>
#include <optional>
#include <string>

#include "api/http_types.h"
#include "server/cors.h"

namespace zoomwarp::server {

// The api::Request of header `h`, without body. Its client_address is `peer` (the socket's
// address), or with `trust_forwarded_for` the last X-Forwarded-For entry when that is an address.
api::Request request_from_header(const boost::beast::http::request_header<>& h, const std::string& peer,
                                 bool trust_forwarded_for);

// Request smuggling defence: nullopt for no Transfer-Encoding or just "chunked", the only coding
// we read [RFC 9112 §6.1]; else 400 bad_transfer_encoding or 501 unsupported_transfer_encoding.
std::optional<api::Response> refuse_transfer_encoding(const boost::beast::http::request_header<>& h);

// Whether answers of `status` have no body (1xx, 204, 304): no Content-Length, nothing sent.
bool bodiless_status(int status);

// Appends the head of `r` to `out`: the status line (`version` 10: HTTP/1.0, else 1.1), Server,
// Content-Type, r.headers, `cors`, Content-Length (r.body's size, also for a HEAD) unless
// bodiless_status(), Connection, and the blank line. Values with a line break are dropped rather
// than let split the head. The head is written by hand and sent with the body in one gather
// write: Beast's serializer costs several times more per request than everything else on the
// cached-tile path.
void append_response_head(std::string& out, const api::Response& r, unsigned version, const HeaderList& cors,
                          bool keep_alive);

}  // namespace zoomwarp::server
