#include "tests/support/metrics_scrape.h"

#include <chrono>
#include <cstdlib>
#include <thread>

#include "tests/support/http_client.h"

namespace zoomwarp::testing {

double metric(int port, const std::string& series) {
  const std::string body = "\n" + HttpClient(port).get("/metrics").body;
  const std::size_t at = body.find("\n" + series + " ");
  return at == std::string::npos ? 0 : std::strtod(body.c_str() + at + series.size() + 2, nullptr);
}

bool wait_for_metric(int port, const std::string& series, double value, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (metric(port, series) < value) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace zoomwarp::testing
