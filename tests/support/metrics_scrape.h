// Reading the server's /metrics in tests: one series' value, and waiting for a counter (a
// request's metrics are counted once its response is written, a moment after the client has it).
#pragma once

#include <string>

namespace zoomwarp::testing {

// The value of one Prometheus series, e.g. `zoomwarp_workers_busy{pool="cpu"}`; 0 when absent.
double metric(int port, const std::string& series);

// Polls until the series reaches `value`; false if it has not after `seconds` (a bound on a hang).
bool wait_for_metric(int port, const std::string& series, double value, double seconds = 60);

}  // namespace zoomwarp::testing
