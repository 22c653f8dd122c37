// A link-time seam for test builds (issue 17): the hook api::Router calls on the worker just
// before it computes an image response (api/router.h RouterConfig::compute_hook).
//
// The shipped `zoomwarp` links compute_hook_none.cc: no hook, and nothing of the test hooks is in
// the binary (no route, no flag, no environment variable). The cluster test's
// `zoomwarp_poisonable` (tests/CMakeLists.txt) links tests/support/compute_hook_poison.cc instead,
// which makes one request abort the process or run until its deadline.
//
// Threads: called once, at start-up; the hook it returns is called from any worker thread.
#pragma once

#include <functional>

#include "api/http_types.h"

namespace zoomwarp::server {

std::function<void(const api::Request&)> compute_hook();

}  // namespace zoomwarp::server
