// Request deadlines, cancellation and the drain timeout, against the real server: a view that runs
// out of --request-timeout is answered 503 with Retry-After and frees its worker; a client that
// hangs up cancels its running or queued request; one client hanging up does not fail another
// waiting for the same view (single flight); --drain-timeout ends the process with requests still
// running.
//
// Slow work is real work: ICAZ views of the 4:1 panorama sample at zoom 0 on the largest screen,
// encoded as PNG (about 2 s each on one worker of this 2-core machine; the warp itself is ~0.1 s,
// the render and the encode are the rest). Tests assert statuses, order and counters, never how long something took;
// the waits below are bounds on a hang.
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <cstdlib>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "tests/http/raw_connection.h"
#include "tests/http/pano_server.h"
#include "tests/support/http_client.h"
#include "tests/support/metrics_scrape.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using testing::HttpClient;
using testing::metric;
using testing::RawConnection;
using testing::wait_for_metric;

const std::string kBusy = R"(zoomwarp_workers_busy{pool="cpu"})";
const std::string kQueued = R"(zoomwarp_queue_depth{pool="cpu"})";
std::string stopped(const std::string& reason) {
  return R"(zoomwarp_http_requests_failed_total{route="viewport",reason=")" + reason + "\"}";
}

// A slow, uncached view: ICAZ at zoom 0 on a 4096×4096 screen as PNG; `variant` makes it distinct.
std::string slow_view(int variant) {
  return "/v1/images/pano/viewport?zoom=0&w=4096&h=4096&format=png&cx=" + std::to_string(1000 + variant);
}
std::string raw_get(const std::string& target) { return "GET " + target + " HTTP/1.1\r\nHost: t\r\n\r\n"; }

class Deadline : public testing::PanoServer {};

TEST_F(Deadline, AViewOutOfTimeGets503WithRetryAfterAndTheWorkerIsFreeAfter) {
  start({"--workers", "1", "--request-timeout", "1"});
  // Five distinct slow views at once on one worker take several seconds together (even on a
  // machine five times faster, more than one): at least one runs out of time, while running or
  // while still queued (then it is not computed at all).
  constexpr int kClients = 5;
  std::vector<testing::HttpResponse> answers(kClients);
  std::vector<std::thread> clients;
  for (int i = 0; i < kClients; ++i)
    clients.emplace_back([&, i] { answers[i] = HttpClient(port()).get(slow_view(i)); });
  for (auto& t : clients) t.join();
  int out_of_time = 0;
  for (const auto& a : answers) {
    if (a.status == 200) {
      EXPECT_EQ(a.header("content-type"), "image/png");
      continue;
    }
    ASSERT_EQ(a.status, 503) << a.body;
    ++out_of_time;
    EXPECT_EQ(a.header("retry-after"), "1");
    const auto body = nlohmann::json::parse(a.body, nullptr, false);
    EXPECT_EQ(body["error"]["code"], "deadline_exceeded") << a.body;
  }
  EXPECT_GE(out_of_time, 1);
  // The worker is free: a small view is answered.
  EXPECT_EQ(HttpClient(port()).get("/v1/images/pano/viewport?zoom=1&w=64&h=64").status, 200);
  EXPECT_TRUE(wait_for_metric(port(), stopped("deadline"), out_of_time, 10));  // counted once written
  EXPECT_EQ(metric(port(), stopped("deadline")), out_of_time);
  EXPECT_TRUE(server_->wait_for_log("\"msg\":\"request stopped\""));
  EXPECT_EQ(server_->terminate(), 0);
}

TEST_F(Deadline, AClientThatHangsUpCancelsItsRunningAndItsQueuedRequest) {
  start({"--workers", "1", "--request-timeout", "600"});
  RawConnection running(port()), queued(port());
  running.send(raw_get(slow_view(0)));
  ASSERT_TRUE(wait_for_metric(port(), kBusy, 1));
  queued.send(raw_get(slow_view(1)));
  ASSERT_TRUE(wait_for_metric(port(), kQueued, 1));
  queued.close();
  running.close();
  // One worker, two slow views before it: answered once both are cancelled (or, without
  // cancellation, after both ran to the end, and then the counter below stays at 0).
  EXPECT_EQ(HttpClient(port()).get("/v1/images/pano/viewport?zoom=1&w=64&h=64").status, 200);
  EXPECT_TRUE(wait_for_metric(port(), stopped("cancelled"), 2, 10)) << metric(port(), stopped("cancelled"));
  EXPECT_EQ(server_->terminate(), 0);
}

TEST_F(Deadline, OneClientHangingUpDoesNotFailAnotherWaitingForTheSameView) {
  start({"--workers", "2", "--request-timeout", "600"});
  RawConnection first(port());
  first.send(raw_get(slow_view(0)));  // computes (single flight's leader)
  ASSERT_TRUE(wait_for_metric(port(), kBusy, 1));
  testing::HttpResponse second;
  std::thread waiter([&] { second = HttpClient(port()).get(slow_view(0)); });  // waits for the first
  ASSERT_TRUE(wait_for_metric(port(), kBusy, 2));
  first.close();
  waiter.join();
  EXPECT_EQ(second.status, 200) << second.body;
  EXPECT_EQ(second.header("content-type"), "image/png");
  EXPECT_TRUE(wait_for_metric(port(), stopped("cancelled"), 1, 10)) << "the first request was cancelled";
  EXPECT_EQ(metric(port(), stopped("cancelled")), 1);
  EXPECT_EQ(server_->terminate(), 0);
}

// --drain-timeout is a promise to the orchestrator: with a view still running when it has passed,
// the process cancels it and exits (0: the stop was asked for) instead of waiting for it.
TEST_F(Deadline, DrainTimeoutEndsTheProcessWithARequestStillRunning) {
  start({"--workers", "1", "--request-timeout", "600", "--drain-delay", "0", "--drain-timeout", "1"});
  RawConnection slow(port());
  slow.send(raw_get(slow_view(0)));
  ASSERT_TRUE(wait_for_metric(port(), kBusy, 1));
  const auto signalled = std::chrono::steady_clock::now();
  const int status = server_->terminate(10);  // SIGTERM; -1 if still running 10 s later
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count();
  std::cout << "exited " << seconds << " s after SIGTERM with --drain-timeout 1\n";
  EXPECT_EQ(status, 0) << "-1: still running 10 s after SIGTERM";
  EXPECT_NE(server_->log().find("\"msg\":\"drain timed out\""), std::string::npos);
  const auto answer = slow.read_until_close(5000);
  EXPECT_TRUE(answer.closed);
  EXPECT_EQ(answer.bytes.find("200 OK"), std::string::npos) << "the view was not finished";
}

}  // namespace
}  // namespace zoomwarp
