// `zoomwarp_poisonable` (tests/support/compute_hook_poison.cc), the cluster test's stand-in for an
// unknown crash and for a request that holds its worker until the deadline, checked here on one
// server: the poisoned request kills the process with SIGABRT and gets no answer, other requests are
// served until then; the slow one is a 503 deadline_exceeded, then remembered by the failure cache.
// And the shipped `zoomwarp` holds nothing of the hook.
#include <gtest/gtest.h>

#include <signal.h>

#include <nlohmann/json.hpp>
#include <optional>

#include "tests/http/pano_server.h"
#include "tests/support/http_client.h"
#include "tests/support/metrics_scrape.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using testing::HttpClient;
using testing::ServerProcess;

const std::string kPoison = "/v1/images/pano/viewport?zoom=0.5&w=64&h=64";
const std::string kSlow = "/v1/images/pano/viewport?zoom=0.25&w=64&h=64";

class Poisonable : public testing::PanoServer {
 protected:
  void start(const std::vector<std::string>& args) {
    PanoServer::start(args, {testing::zoomwarp_poisonable_binary(),
                             {{"ZOOMWARP_TEST_POISON", kPoison}, {"ZOOMWARP_TEST_SLOW", kSlow}}});
  }
};

TEST_F(Poisonable, ThePoisonedRequestAbortsTheProcessWithoutAnAnswer) {
  start({});
  EXPECT_EQ(HttpClient(port()).get("/v1/images/pano/viewport?zoom=0.5&w=64&h=65").status, 200) << "a neighbour is served";
  const std::string answer = testing::raw_exchange(port(), "GET " + kPoison + " HTTP/1.1\r\nHost: t\r\n\r\n");
  EXPECT_EQ(answer, "") << "no answer, not even an error";
  EXPECT_EQ(server_->wait_for_end(10), SIGABRT);
}

TEST_F(Poisonable, TheSlowRequestRunsUntilItsDeadlineAndIsRemembered) {
  start({"--request-timeout", "1", "--failure-cache-ms", "60000"});
  HttpClient http(port());
  const auto first = http.get(kSlow);
  EXPECT_EQ(first.status, 503) << first.body;
  EXPECT_EQ(nlohmann::json::parse(first.body, nullptr, false)["error"]["code"], "deadline_exceeded") << first.body;
  EXPECT_EQ(http.get(kSlow).status, 503);
  EXPECT_TRUE(testing::wait_for_metric(
      port(), R"(zoomwarp_http_requests_failed_total{route="viewport",reason="negative_cache"})", 1, 10));
  EXPECT_EQ(http.get("/v1/images/pano/viewport?zoom=0.25&w=64&h=65").status, 200) << "a neighbour is served";
  EXPECT_EQ(server_->terminate(), 0);
}

// The hook is a test build's only: the shipped binary holds neither its variables nor its code.
TEST(ShippedBinary, HoldsNoTestHook) {
  const std::string shipped = testing::read_file(testing::zoomwarp_binary());
  const std::string poisonable = testing::read_file(testing::zoomwarp_poisonable_binary());
  ASSERT_FALSE(shipped.empty());
  for (const std::string name : {"ZOOMWARP_TEST_POISON", "ZOOMWARP_TEST_SLOW"}) {
    EXPECT_EQ(shipped.find(name), std::string::npos) << name;
    EXPECT_NE(poisonable.find(name), std::string::npos) << name << ": the test build has it, so this test can fail";
  }
}

}  // namespace
}  // namespace zoomwarp
