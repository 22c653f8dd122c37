// The failure cache (issue 17, api/failure_cache.h), against the real server: a view that ran out
// of time, or failed with a 500, asked again within --failure-cache-ms is answered with the same
// failure and Retry-After at once, without a worker; after the window it is computed again; a
// request whose client left is not remembered. /metrics counts the failures by route and reason.
//
// "Without a worker" is zoomwarp_worker_jobs_total{pool="cpu"} not moving, never a time measured.
// A view that runs out of time whatever the machine's speed: zoomwarp_poisonable's
// ZOOMWARP_TEST_SLOW view holds its worker until the deadline (tests/support/compute_hook_poison.cc;
// the same server otherwise). A client that hangs up leaves a real slow view, as in
// http_deadline_test.cc: ICAZ at zoom 0 on a 4096×4096 screen as PNG (about 1-2 s here).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "tests/http/raw_connection.h"
#include "tests/http/pano_server.h"
#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/metrics_scrape.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using testing::HttpClient;
using testing::metric;
using testing::wait_for_metric;

const std::string kJobs = R"(zoomwarp_worker_jobs_total{pool="cpu"})";
std::string failed(const std::string& route, const std::string& reason) {
  return R"(zoomwarp_http_requests_failed_total{route=")" + route + R"(",reason=")" + reason + "\"}";
}

const std::string kSlowView = "/v1/images/pano/viewport?zoom=0&w=4096&h=4096&format=png&cx=1000";
// Held until its deadline by zoomwarp_poisonable; the same view with its parameters in another
// order is the same canonical request.
const std::string kOutOfTime = "/v1/images/pano/viewport?zoom=0.5&w=64&h=64&cx=1000";
const std::string kOutOfTimeReordered = "/v1/images/pano/viewport?cx=1000&h=64&w=64&zoom=0.5";
const testing::ServerExecutable kPoisonable{testing::zoomwarp_poisonable_binary(), {{"ZOOMWARP_TEST_SLOW", kOutOfTime}}};

std::string error_code(const testing::HttpResponse& r) {
  const auto body = nlohmann::json::parse(r.body, nullptr, false);
  return body.is_object() ? body["error"].value("code", "") : "";
}

class FailureCache : public testing::PanoServer {};

TEST_F(FailureCache, AViewOutOfTimeIsAnsweredFromTheCacheUntilItsWindowPasses) {
  start({"--workers", "1", "--request-timeout", "1", "--failure-cache-ms", "4000"}, kPoisonable);
  HttpClient http(port());
  const double jobs_before = metric(port(), kJobs);
  const auto first = http.get(kOutOfTime);
  ASSERT_EQ(first.status, 503) << first.body;
  EXPECT_EQ(error_code(first), "deadline_exceeded");
  ASSERT_TRUE(wait_for_metric(port(), failed("viewport", "deadline"), 1, 10));
  const double jobs_computed = metric(port(), kJobs);
  EXPECT_EQ(jobs_computed, jobs_before + 1);

  // Asked again at once, also with its parameters in another order: the same answer, from memory.
  for (const std::string& target : {kOutOfTime, kOutOfTimeReordered}) {
    const auto again = http.get(target);
    EXPECT_EQ(again.status, 503) << target;
    EXPECT_EQ(again.body, first.body) << target;
    EXPECT_EQ(again.header("content-type"), "application/json");
    const int retry_after = std::atoi(again.header("retry-after").c_str());
    EXPECT_GE(retry_after, 1) << again.header("retry-after");
    EXPECT_LE(retry_after, 4) << again.header("retry-after");
  }
  EXPECT_TRUE(wait_for_metric(port(), failed("viewport", "negative_cache"), 2, 10));
  EXPECT_EQ(metric(port(), failed("viewport", "negative_cache")), 2);
  EXPECT_EQ(metric(port(), kJobs), jobs_computed) << "a remembered failure takes no worker";
  EXPECT_EQ(metric(port(), failed("viewport", "deadline")), 1);

  // After the window (as long as the last Retry-After said) the view is computed again.
  const auto last = http.get(kOutOfTime);
  std::this_thread::sleep_for(std::chrono::seconds(std::atoi(last.header("retry-after").c_str())) +
                              std::chrono::milliseconds(100));
  const auto recomputed = http.get(kOutOfTime);
  EXPECT_EQ(recomputed.status, 503);
  EXPECT_EQ(error_code(recomputed), "deadline_exceeded");
  EXPECT_TRUE(wait_for_metric(port(), failed("viewport", "deadline"), 2, 10));
  EXPECT_EQ(metric(port(), kJobs), jobs_computed + 1);
  EXPECT_EQ(server_->terminate(), 0);
}

TEST_F(FailureCache, ZeroDisablesIt) {
  start({"--workers", "1", "--request-timeout", "1", "--failure-cache-ms", "0"}, kPoisonable);
  HttpClient http(port());
  for (int i = 0; i < 2; ++i) EXPECT_EQ(error_code(http.get(kOutOfTime)), "deadline_exceeded");
  EXPECT_TRUE(wait_for_metric(port(), failed("viewport", "deadline"), 2, 10));
  EXPECT_EQ(metric(port(), failed("viewport", "negative_cache")), 0);
  EXPECT_EQ(server_->terminate(), 0);
}

// A client that hangs up says nothing about the view: the next request for it is computed.
TEST_F(FailureCache, ACancelledViewIsNotRemembered) {
  start({"--workers", "1", "--request-timeout", "600", "--failure-cache-ms", "60000"});
  testing::RawConnection leaving(port());
  leaving.send("GET " + kSlowView + " HTTP/1.1\r\nHost: t\r\n\r\n");
  ASSERT_TRUE(wait_for_metric(port(), R"(zoomwarp_workers_busy{pool="cpu"})", 1));
  leaving.close();
  ASSERT_TRUE(wait_for_metric(port(), failed("viewport", "cancelled"), 1));
  const auto answer = HttpClient(port()).get(kSlowView);
  EXPECT_EQ(answer.status, 200) << answer.body;
  EXPECT_EQ(answer.header("content-type"), "image/png");
  EXPECT_EQ(metric(port(), failed("viewport", "negative_cache")), 0);
  EXPECT_EQ(server_->terminate(), 0);
}

// Tile files broken on disk behind a fresh server (as in http_protocol_test.cc): reading them is a
// generic 500, logged once; the same request again is the same 500 from memory, not read or logged
// again. Another request of the same image is computed (and fails) on its own.
TEST_F(FailureCache, AnInternalErrorIsRememberedAndLoggedOnce) {
  testing::TempDir dir;
  const std::string store = dir.path() + "/store", image = dir.path() + "/small.png";
  testing::write_image(image, testing::resize(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"), 640, 400));
  {
    testing::ServerProcess first(store);
    ASSERT_EQ(HttpClient(first.port()).request("POST", "/v1/images?id=a", testing::read_file(image)).status, 201);
    ASSERT_EQ(first.terminate(), 0);
  }
  for (const auto& f : std::filesystem::recursive_directory_iterator(store + "/versions"))
    if (f.path().extension() == ".tif") std::ofstream(f.path(), std::ios::trunc) << "not a TIFF";
  testing::ServerProcess server(store, {"--failure-cache-ms", "60000"});
  HttpClient http(server.port());
  const std::string target = "/iiif/3/a/full/300,/0/default.jpg";
  const auto first = http.get(target);
  ASSERT_EQ(first.status, 500) << first.body;
  EXPECT_EQ(error_code(first), "internal_error");
  ASSERT_TRUE(wait_for_metric(server.port(), failed("iiif_image", "internal_error"), 1, 10));
  const double jobs = metric(server.port(), kJobs);

  const auto again = http.get(target);
  EXPECT_EQ(again.status, 500);
  EXPECT_EQ(again.body, first.body);
  EXPECT_FALSE(again.header("retry-after").empty());
  EXPECT_TRUE(wait_for_metric(server.port(), failed("iiif_image", "negative_cache"), 1, 10));
  EXPECT_EQ(metric(server.port(), kJobs), jobs) << "a remembered failure takes no worker";

  EXPECT_EQ(http.get("/iiif/3/a/full/200,/0/default.jpg").status, 500) << "another request is its own";
  EXPECT_TRUE(wait_for_metric(server.port(), failed("iiif_image", "internal_error"), 2, 10));
  EXPECT_EQ(metric(server.port(), kJobs), jobs + 1);
  // One "request failed" line per computed failure, none for the remembered one (each is logged
  // just after its answer is written: waited for, with a bound on a hang).
  const auto logged = [&] {
    const std::string log = server.log(), line = "\"msg\":\"request failed\"";
    int n = 0;
    for (std::size_t at = log.find(line); at != std::string::npos; at = log.find(line, at + 1)) ++n;
    return n;
  };
  for (int i = 0; i < 1000 && logged() < 2; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(logged(), 2);
  EXPECT_EQ(server.terminate(), 0);
}

}  // namespace
}  // namespace zoomwarp
