// `zoomwarp serve --store s3://…` against OpenStack Swift's s3api on loopback (tests/support/
// swift_s3.h; suite S3Serve, one process, one Swift): what issue 29's acceptance asks of servers
// that share nothing but a bucket. Two servers with their own working folders: an upload on one is
// served by the other and a delete is seen by both. A paused store (SIGSTOP of Swift's proxy)
// gives bounded 503/504 answers with JSON bodies while the process stays live and /readyz says
// why; service returns by itself when the store does. An upload cut while the store hangs (the
// server killed mid-commit) publishes nothing.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <signal.h>

#include <chrono>
#include <functional>
#include <thread>

#include "tests/support/http_client.h"
#include "tests/support/server_process.h"
#include "tests/support/swift_s3.h"
#include "tiles/s3_client.h"
#include "tiles/store.h"

namespace zoomwarp {
namespace {

using Clock = std::chrono::steady_clock;
using test::SwiftS3;
using testing::HttpClient;
using testing::ServerProcess;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Polls `done` every 50 ms for up to `seconds`; whether it came true.
bool eventually(double seconds, const std::function<bool()>& done) {
  const auto t0 = Clock::now();
  while (seconds_since(t0) < seconds) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return done();
}

class S3Serve : public ::testing::Test {
 protected:
  void SetUp() override {
    SwiftS3& s3 = SwiftS3::shared();
    for (const auto& [k, v] : s3.environment()) ::setenv(k.c_str(), v.c_str(), 1);
    location_ = "s3://" + s3.new_bucket("serve") + "/museum";
  }
  void TearDown() override {
    if (paused_) SwiftS3::shared().resume();
  }

  // A replica: its own working folder (staging, disk cache), pointers trusted for `recheck_ms`,
  // views bounded by 2 s.
  std::unique_ptr<ServerProcess> replica(const testing::TempDir& dir, const std::string& recheck_ms = "200") {
    return std::make_unique<ServerProcess>(
        location_, std::vector<std::string>{"--store-cache", dir.path(), "--store-recheck-ms", recheck_ms,
                                            "--request-timeout", "2", "--workers", "2"});
  }

  void pause() {
    SwiftS3::shared().pause();
    paused_ = true;
  }
  void resume() {
    SwiftS3::shared().resume();
    paused_ = false;
  }

  std::string location_;
  bool paused_ = false;
};

const std::string& boats() {
  static const std::string bytes = testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg");
  return bytes;
}

TEST_F(S3Serve, AnUploadOnOneServerIsServedByTheOtherAndADeleteIsSeenByBoth) {
  testing::TempDir a_dir, b_dir;
  auto a = replica(a_dir), b = replica(b_dir);
  HttpClient on_a(a->port()), on_b(b->port());
  EXPECT_EQ(on_b.get("/v1/images/boats").status, 404);
  ASSERT_EQ(on_a.request("POST", "/v1/images?id=boats", boats()).status, 201);
  EXPECT_TRUE(eventually(3, [&] { return on_b.get("/v1/images/boats").status == 200; }))
      << "an upload on a is served by b";
  for (const char* tile : {"/dzi/boats_files/12/3_2.jpg", "/dzi/boats_files/9/0_0.jpg", "/iiif/3/boats/full/max/0/default.jpg"}) {
    const auto from_a = on_a.get(tile), from_b = on_b.get(tile);
    EXPECT_EQ(from_b.status, 200) << tile << ": " << from_b.body;
    EXPECT_TRUE(from_a.body == from_b.body) << tile << ": the same bytes from both";
  }
  // A first view may be answered 503 analysis_pending with Retry-After while its analysis (the
  // model and the detected lines, read from the bucket) is made: retried as a client would.
  int view_status = 0;
  EXPECT_TRUE(eventually(30, [&] {
    view_status = on_b.get("/v1/images/boats/viewport?zoom=0&w=360&h=640").status;
    return view_status != 503;
  }));
  EXPECT_EQ(view_status, 200);

  EXPECT_EQ(on_a.request("DELETE", "/v1/images/boats").status, 204);
  EXPECT_EQ(on_a.get("/v1/images/boats").status, 404) << "the deleting server at once";
  EXPECT_TRUE(eventually(3, [&] { return on_b.get("/v1/images/boats").status == 404; }))
      << "the other within its --store-recheck-ms";
  EXPECT_EQ(on_b.get("/dzi/boats_files/12/3_2.jpg").status, 404);
}

// `paths` asked for at once, each by a client of its own, while a probe checks liveness; each
// answer must be a 503/504 with a JSON error within `seconds`.
void expect_bounded_failures(int port, const std::vector<std::string>& paths, double seconds) {
  std::vector<testing::HttpResponse> answers(paths.size());
  std::vector<double> took(paths.size());
  {
    std::vector<std::thread> clients;
    for (std::size_t i = 0; i < paths.size(); ++i)
      clients.emplace_back([&, i] {
        HttpClient c(port);
        const auto t0 = Clock::now();
        answers[i] = c.get(paths[i]);
        took[i] = seconds_since(t0);
      });
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto t0 = Clock::now();
    HttpClient probe(port);
    EXPECT_EQ(probe.get("/healthz").status, 200) << "liveness holds while the workers wait for the store";
    EXPECT_LT(seconds_since(t0), 1.0);
    for (auto& t : clients) t.join();
  }
  for (std::size_t i = 0; i < paths.size(); ++i) {
    EXPECT_TRUE(answers[i].status == 503 || answers[i].status == 504) << paths[i] << ": " << answers[i].status << " " << answers[i].body;
    EXPECT_LT(took[i], seconds) << paths[i] << ": bounded";
    const auto body = nlohmann::json::parse(answers[i].body, nullptr, false);
    ASSERT_TRUE(body.is_object()) << answers[i].body;
    const std::string code = body["error"]["code"].get<std::string>();
    EXPECT_TRUE(code == "store_timeout" || code == "store_unavailable" || code == "deadline_exceeded") << code;
    EXPECT_EQ(answers[i].header("retry-after"), "1");
  }
}

TEST_F(S3Serve, APausedStoreGivesBoundedAnswersAndServiceReturnsWithIt) {
  testing::TempDir dir;
  auto server = replica(dir);
  HttpClient http(server->port());
  ASSERT_EQ(http.request("POST", "/v1/images?id=boats", boats()).status, 201);
  const std::vector<std::string> read_before = {"/dzi/boats_files/12/0_0.jpg",  // level 0 open in OpenImageIO
                                                "/iiif/3/boats/0,0,256,256/256,/0/default.jpg"};  // and in libtiff
  std::vector<std::string> bytes_before;
  for (const auto& path : read_before) {
    const auto r = http.get(path);
    ASSERT_EQ(r.status, 200) << path;
    bytes_before.push_back(r.body);
  }
  ASSERT_EQ(http.get("/readyz").status, 200);

  pause();
  // Past --store-recheck-ms, before readiness has noticed: each request's image is looked up in the
  // store again, which the I/O thread must not wait for (it would hold /healthz with it) and a
  // worker only until the deadline. As many as there are workers, so that none fails by waiting
  // in the queue instead.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const std::vector<std::string> unread = {"/dzi/boats_files/12/9_5.jpg", "/iiif/3/boats/2304,1280,256,256/256,/0/default.jpg"};
  expect_bounded_failures(server->port(), unread, 2 + 1.5);
  testing::HttpResponse ready;
  EXPECT_TRUE(eventually(5, [&] { return (ready = http.get("/readyz")).status == 503; })) << "readiness fails";
  EXPECT_NE(ready.body.find("store not readable"), std::string::npos) << ready.body;
  EXPECT_EQ(http.get("/healthz").status, 200);

  // Known down: what was read before is served from what the server holds, and the rest fails at
  // once rather than after the deadline, also inside the level readers, which pass the store's
  // failure on: OpenImageIO's pixels (a Deep Zoom tile with overlap) and libtiff's stored tiles (a
  // IIIF tile that is one stored tile, sent as it is), both of a level they have open.
  for (std::size_t i = 0; i < read_before.size(); ++i) {
    const auto r = http.get(read_before[i]);
    EXPECT_EQ(r.status, 200) << read_before[i] << " is served from the caches: " << r.body;
    EXPECT_TRUE(r.body == bytes_before[i]) << read_before[i];
  }
  const std::vector<std::string> more = {"/dzi/boats_files/12/8_5.jpg", "/iiif/3/boats/2048,1280,256,256/256,/0/default.jpg",
                                         "/iiif/3/boats/1024,768,512,512/256,/0/default.jpg"};
  expect_bounded_failures(server->port(), more, 0.5);

  resume();
  EXPECT_TRUE(eventually(10, [&] { return http.get("/readyz").status == 200; })) << "ready again with the store";
  // Served again once the store answers (a store's failure is not remembered for the view, as a
  // deadline's is for --failure-cache-ms).
  for (const auto& path : {unread[0], unread[1], more[0], more[1], more[2], std::string("/v1/images/boats")}) {
    testing::HttpResponse back;
    EXPECT_TRUE(eventually(10, [&] { return (back = http.get(path)).status == 200; }))
        << path << " is served again: " << back.status << " " << back.body;
  }
  const std::string metrics = http.get("/metrics").body;
  EXPECT_NE(metrics.find("zoomwarp_store_readable 1"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find(",reason=\"store\"}"), std::string::npos) << "the store's failures are counted";
}

TEST_F(S3Serve, AnUploadCutWhileTheStoreHangsPublishesNothing) {
  testing::TempDir dir;
  auto server = replica(dir);
  pause();
  std::thread upload([&] {
    try {
      HttpClient c(server->port());
      c.request("POST", "/v1/images?id=cut", boats());
    } catch (const std::exception&) {  // the connection is cut with the server
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // staged, its commit waiting for the store
  ::kill(server->pid(), SIGKILL);
  EXPECT_EQ(server->wait_for_end(10), SIGKILL);
  upload.join();
  resume();
  // A request the paused proxy had received whole is carried out once it runs again.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));

  tiles::Store store(location_, std::chrono::milliseconds(0));
  EXPECT_FALSE(store.published("cut")) << "no pointer: nothing published";
  EXPECT_FALSE(store.find("cut"));
  store.collect_garbage(std::chrono::seconds(0));
  tiles::S3Client client(tiles::S3Config::from_environment());
  const std::string bucket = location_.substr(5, location_.find('/', 5) - 5);
  const auto left = client.list(bucket, "museum/versions/", "", "", Clock::now() + std::chrono::seconds(10));
  EXPECT_TRUE(left.objects.empty()) << left.objects.size() << " objects of the cut upload left after collection, first "
                                    << left.objects.front().key;
}

}  // namespace
}  // namespace zoomwarp
