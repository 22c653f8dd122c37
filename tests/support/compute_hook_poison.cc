// The compute hook of `zoomwarp_poisonable` (server/compute_hook.h), for the cluster test's poison
// and slow-request cases (issue 17): a replica that dies on one specific request, and one whose
// request runs until its deadline, among otherwise real replicas. Never linked into `zoomwarp`.
//
// ZOOMWARP_TEST_POISON=TARGET: a request for exactly TARGET (path and query as sent, e.g.
//   /v1/images/a/viewport?zoom=0.5&w=64&h=64) aborts the process (SIGABRT) on the worker that
//   computes it, as an unknown crash would.
// ZOOMWARP_TEST_SLOW=TARGET: a request for TARGET holds its worker, sleeping, until its deadline
//   (--request-timeout) or cancellation stops it: answered 503 deadline_exceeded, and remembered
//   by the failure cache like any view that runs out of time.
//
// Only requests the router computes reach the hook (views, tiles, IIIF images not in a cache).
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>

#include "server/compute_hook.h"
#include "warp/core/stop_token.h"

namespace zoomwarp::server {

namespace {
std::string env(const char* name) {
  const char* value = std::getenv(name);
  return value ? value : "";
}
}  // namespace

std::function<void(const api::Request&)> compute_hook() {
  const std::string poison = env("ZOOMWARP_TEST_POISON"), slow = env("ZOOMWARP_TEST_SLOW");
  if (poison.empty() && slow.empty()) return {};
  return [poison, slow](const api::Request& req) {
    const std::string target = req.query.empty() ? req.path : req.path + "?" + req.query;
    if (target == poison) std::abort();
    if (target != slow || !req.stop) return;
    while (true) {
      req.stop->check();  // throws warp::Stopped at the deadline
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  };
}

}  // namespace zoomwarp::server
