#include "api/authorize.h"

#include "api/errors.h"

namespace zoomwarp::api {

namespace {

constexpr const char* kRealm = "Bearer realm=\"zoomwarp\"";

Response denied(int status, const std::string& code, const std::string& message, const std::string& challenge) {
  Response r = error_response(status, code, message);
  r.route = "access_denied";
  r.set_header("WWW-Authenticate", challenge);
  r.set_header("Cache-Control", "no-store");
  return r;
}

Role role_needed(Access needed) { return needed == Access::kAdmin ? Role::kAdmin : Role::kCurator; }

bool keys_configured(const AccessPolicy& policy) { return policy.keys && policy.keys->has_keys(); }

}  // namespace

std::optional<Response> check_access(const AccessPolicy& policy, Access needed, const Request& req) {
  if (needed == Access::kPublic) return std::nullopt;
  if (!keys_configured(policy)) {
    if (needed == Access::kAdmin || policy.open_writes) return std::nullopt;
    Response r = error_response(403, "writes_disabled",
                                "this server takes no writes: its operator starts it with --keys FILE (API keys) "
                                "or --open-writes (anyone may write)");
    r.route = "access_denied";
    return r;
  }
  const Authenticator::Result who = policy.keys->authenticate(req.authorization);
  const std::string role = needed == Access::kAdmin ? "an admin" : "a curator";
  switch (who.outcome) {
    case Authenticator::Outcome::kNoCredentials:
      return denied(401, "key_required", "send " + role + " key as 'Authorization: Bearer KEY'", kRealm);
    case Authenticator::Outcome::kInvalid:
      return denied(401, "invalid_key", "the key is not valid (unknown, revoked, or not sent as 'Bearer KEY')",
                    std::string(kRealm) + ", error=\"invalid_token\"");
    case Authenticator::Outcome::kValid: break;
  }
  if (who.principal.role >= role_needed(needed)) return std::nullopt;
  return denied(403, "insufficient_role", "key '" + who.principal.key_id + "' may not do this: it needs " + role + " key",
                std::string(kRealm) + ", error=\"insufficient_scope\"");
}

}  // namespace zoomwarp::api
