// Operations endpoints: /healthz (the process answers), /readyz (the store could be read at its
// last check, StoreMonitor, and we are not draining; its "checks" also report degraded features that do not make the replica
// unready, such as face detection), /metrics (Prometheus). Answered on the I/O thread; they
// never queue.
//
// Access (api/authorize.h): with keys configured, /metrics needs an admin key (401/403 without),
// and /readyz keeps its status code for everyone (probes send no key) but shows its "checks"
// only to an admin key. Without keys both are open, as before keys existed.
#pragma once

#include <atomic>
#include <optional>
#include <string_view>

#include "api/authorize.h"
#include "api/http_types.h"
#include "server/metrics.h"
#include "server/store_monitor.h"

namespace zoomwarp::server {

struct OpsContext {
  const StoreMonitor& store;
  const Metrics& metrics;
  const std::atomic<bool>& draining;
  std::string_view face_detection;  // "on" or "off: why"
  const api::AccessPolicy& access;
};

// The answer if `req` is an operations endpoint, else nullopt.
std::optional<api::Response> answer_ops(const api::Request& req, const OpsContext& ctx);

}  // namespace zoomwarp::server
