// Who may call what: the access a route requires (the route table says it, api/router.cc; the
// server's /metrics and /readyz details are admin) and the one check every such request passes
// before its handler runs. Answers follow RFC 6750: 401 with `WWW-Authenticate: Bearer
// realm="zoomwarp"` without a usable key (`error="invalid_token"` for a key the server does not
// know), 403 with `error="insufficient_scope"` for a valid key whose role is too low.
//
// Without any key configured nobody can authenticate, so:
//  - curator routes (writes) are refused, 403 `writes_disabled`, unless the operator started the
//    server with --open-writes, which lets anyone write;
//  - admin routes stay open, as they were before keys existed: they reveal no secret, and a
//    server without keys is one its operator has not put on the open internet on purpose.
//
// Threads: check_access() may be called from any thread; the Authenticator is thread-safe.
#pragma once

#include <optional>

#include "api/access.h"
#include "api/http_types.h"

namespace zoomwarp::api {

enum class Access { kPublic, kCurator, kAdmin };

struct AccessPolicy {
  const Authenticator* keys = nullptr;  // null or without keys: none configured
  bool open_writes = false;             // --open-writes: with no keys, anyone may write
};

// nullopt if `req` may call a route requiring `needed`; else the 401 or 403 answer (JSON error,
// route "access_denied"). Never names the key in its answer.
std::optional<Response> check_access(const AccessPolicy& policy, Access needed, const Request& req);

}  // namespace zoomwarp::api
