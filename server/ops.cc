#include "server/ops.h"

#include <nlohmann/json.hpp>

#include "api/errors.h"

namespace zoomwarp::server {

namespace {
api::Response text(int status, std::string content_type, std::string body, std::string route) {
  api::Response r;
  r.status = status;
  r.content_type = std::move(content_type);
  r.body = std::make_shared<const std::string>(std::move(body));
  r.route = std::move(route);
  r.set_header("Cache-Control", "no-store");
  return r;
}
}  // namespace

std::optional<api::Response> answer_ops(const api::Request& req, const OpsContext& ctx) {
  if (req.path != "/healthz" && req.path != "/readyz" && req.path != "/metrics") return std::nullopt;
  if (req.method != "GET" && req.method != "HEAD") {
    api::Response r = api::error_response(405, "method_not_allowed", "allowed methods: GET, HEAD");
    r.set_header("Allow", "GET, HEAD");
    r.route = "ops";
    return r;
  }
  if (req.path == "/healthz") return text(200, "application/json", "{\"status\":\"ok\"}\n", "healthz");
  if (req.path == "/readyz") {
    // Face detection is a detail: without it significance maps are coarser, views still work.
    const StoreMonitor::Reading store = ctx.store.last();
    const bool store_ok = store.problem.empty(), draining = ctx.draining.load();
    nlohmann::json body = {{"status", draining ? "draining" : store_ok ? "ready" : "store not readable"}};
    // The details are for the operator, as /metrics are: with keys configured, for an admin key.
    if (!api::check_access(ctx.access, api::Access::kAdmin, req))
      body["checks"] = {{"store", store_ok ? "ok" : "not readable: " + store.problem},
                        {"face_detection", std::string(ctx.face_detection)}};
    return text(!draining && store_ok ? 200 : 503, "application/json", body.dump() + "\n", "readyz");
  }
  if (auto refusal = api::check_access(ctx.access, api::Access::kAdmin, req)) return refusal;
  return text(200, "text/plain; version=0.0.4; charset=utf-8", ctx.metrics.render(), "metrics");
}

}  // namespace zoomwarp::server
