// The shipped binary's compute hook: none (server/compute_hook.h).
#include "server/compute_hook.h"

namespace zoomwarp::server {

std::function<void(const api::Request&)> compute_hook() { return {}; }

}  // namespace zoomwarp::server
