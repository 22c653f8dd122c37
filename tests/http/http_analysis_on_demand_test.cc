// Analyses on demand (issue 28): an upload publishes the pyramid alone; each (method, saliency)
// analysis is computed on the first view that needs it — once, whatever the number of concurrent
// first views, in the background to completion even when the request that started it runs out
// of time — and kept with the image version, so that another server on the same store reads it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <future>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/metrics_scrape.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HttpClient;

constexpr const char* kComputed = R"(zoomwarp_analyses_total{source="computed"})";
constexpr const char* kRead = R"(zoomwarp_analyses_total{source="read"})";

class AnalysisOnDemand : public ::testing::Test {
 protected:
  void SetUp() override {
    // The bundled 2560×1600 photograph: its analysis image is 1024×640, where every method's
    // analysis takes a good part of a second or more.
    sample_ = testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg");
  }
  std::string store() const { return dir_.path() + "/store"; }

  static json analyses(HttpClient& http, const std::string& id) {
    const auto r = http.get("/v1/images/" + id);
    EXPECT_EQ(r.status, 200) << r.body;
    return json::parse(r.body).at("analyses");
  }
  static bool holds(const json& list, const std::string& name) {
    return std::find(list.begin(), list.end(), name) != list.end();
  }
  // Polls GET /v1/images/{id} until it lists `name` (bounded: a hang fails the test).
  static bool wait_for_analysis(HttpClient& http, const std::string& id, const std::string& name) {
    for (int i = 0; i < 1200; ++i) {
      if (holds(analyses(http, id), name)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return false;
  }
  void upload(HttpClient& http, const std::string& id) {
    const auto r = http.request("POST", "/v1/images?id=" + id, sample_);
    ASSERT_EQ(r.status, 201) << r.body;
  }

  testing::TempDir dir_;
  std::string sample_;
};

TEST_F(AnalysisOnDemand, AnUploadPublishesThePyramidAloneAndAFirstViewAddsItsMethodsAnalysis) {
  testing::ServerProcess server(store());
  HttpClient http(server.port());
  upload(http, "boats");
  EXPECT_EQ(analyses(http, "boats"), json::array()) << "nothing analysed at upload";
  EXPECT_EQ(http.get("/iiif/3/boats/0,0,512,512/256,/0/default.jpg").status, 200) << "tiles at once";

  const auto view = http.get("/v1/images/boats/viewport?method=patch&zoom=0&w=360&h=640");
  ASSERT_EQ(view.status, 200) << view.body;
  const json held = analyses(http, "boats");
  EXPECT_TRUE(holds(held, "icaz.default")) << held << ": every method reads the model";
  EXPECT_TRUE(holds(held, "patch.default")) << held;
  EXPECT_FALSE(holds(held, "patch.gbvs")) << held << ": only what was asked for";
  EXPECT_FALSE(holds(held, "seam.default")) << held;
  EXPECT_EQ(testing::metric(server.port(), kComputed), 2) << "the model and patch's precomputation";
}

TEST_F(AnalysisOnDemand, ConcurrentFirstViewsComputeOnce) {
  testing::ServerProcess server(store(), {"--workers", "4"});
  HttpClient http(server.port());
  upload(http, "boats");
  // Different views (the router's own single flight would merge identical ones), one analysis.
  std::vector<std::future<int>> views;
  for (const char* zoom : {"0", "0.2", "0.4", "0.6"})
    views.push_back(std::async(std::launch::async, [&, zoom] {
      HttpClient client(server.port());
      return client.get(std::string("/v1/images/boats/mesh?method=mp&w=480&h=360&zoom=") + zoom).status;
    }));
  for (auto& v : views) EXPECT_EQ(v.get(), 200);
  EXPECT_EQ(testing::metric(server.port(), kComputed), 2) << "the model and mp's precomputation, once each";
}

// The request that started an analysis runs out of time: it is answered 503 analysis_pending with
// Retry-After (not the failure cache's deadline answer), the analysis goes on to the end in the
// background, and the retry is answered from it without computing it again.
TEST_F(AnalysisOnDemand, AFirstViewOutOfTimeLeavesTheWorkToFinishForItsRetry) {
  // Three workers: each of the three first views holds one while it waits for its analysis; with
  // two, this view waited for a worker while the others waited out their second, and on a loaded
  // machine its own second ran out in the queue — answered deadline_exceeded, its analysis never
  // asked for.
  testing::ServerProcess server(store(), {"--request-timeout", "1", "--failure-cache-ms", "60000", "--analysis-threads",
                                          "1", "--workers", "3"});
  HttpClient http(server.port());
  upload(http, "boats");
  // The one analysis thread busy with two other first views (about two seconds of work), so that
  // this view's analysis, queued behind them, cannot end within its own second on any machine
  // (alone it takes 0.6–0.9 s on a fast one, and then its render, not its analysis, ran out of time).
  std::vector<std::future<int>> busy;
  for (const char* method : {"retarget-zoom", "seam"}) {
    busy.push_back(std::async(std::launch::async, [&, method] {
      HttpClient other(server.port());
      return other.get(std::string("/v1/images/boats/viewport?saliency=gbvs&zoom=0&w=360&h=640&method=") + method).status;
    }));
    for (int i = 0; i < 400 && testing::metric(server.port(), "zoomwarp_analyses_pending") < int(busy.size()); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const std::string view = "/v1/images/boats/viewport?method=polyfem&saliency=gbvs&zoom=0&w=360&h=640";
  const auto first = http.get(view);
  ASSERT_EQ(first.status, 503) << first.body;
  EXPECT_EQ(json::parse(first.body)["error"]["code"], "analysis_pending") << first.body;
  EXPECT_FALSE(first.header("retry-after").empty());
  ASSERT_TRUE(wait_for_analysis(http, "boats", "polyfem.gbvs")) << "the work was not cancelled with its request";
  // Counted once its flight lands, a moment after the file is written.
  for (int i = 0; i < 600 && testing::metric(server.port(), "zoomwarp_analyses_pending") > 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_EQ(testing::metric(server.port(), "zoomwarp_analyses_pending"), 0);
  const double computed = testing::metric(server.port(), kComputed);
  const auto retry = http.get(view);
  EXPECT_EQ(retry.status, 200) << retry.body;
  EXPECT_EQ(testing::metric(server.port(), kComputed), computed) << "the retry computed nothing again";
  for (auto& b : busy) {
    const int status = b.get();
    EXPECT_TRUE(status == 200 || status == 503) << status;
  }
}

TEST_F(AnalysisOnDemand, ASecondServerOnTheStoreReadsTheStoredAnalysis) {
  const std::string view = "/v1/images/boats/viewport?method=seam&zoom=0&w=360&h=640";
  std::string first_body;
  {
    testing::ServerProcess first(store());
    HttpClient http(first.port());
    upload(http, "boats");
    const auto r = http.get(view);
    ASSERT_EQ(r.status, 200) << r.body;
    first_body = r.body;
  }
  testing::ServerProcess second(store());
  HttpClient http(second.port());
  const auto r = http.get(view);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.body, first_body) << "the same view from the stored analysis";
  EXPECT_EQ(testing::metric(second.port(), kComputed), 0) << "nothing computed again";
  EXPECT_EQ(testing::metric(second.port(), kRead), 2) << "the model and seam's maps, read";
}

// An edit precomputes again the methods' files its version holds, and makes no others.
TEST_F(AnalysisOnDemand, AnEditRecomputesOnlyWhatTheVersionHolds) {
  testing::ServerProcess server(store());
  HttpClient http(server.port());
  upload(http, "boats");
  ASSERT_EQ(http.get("/v1/images/boats/viewport?method=patch&zoom=0&w=360&h=640").status, 200);
  const json regions = {{"regions", {{{"rect", {0, 0, 800, 800}}, {"weight", 1}}}}};
  const auto edit = http.request("PATCH", "/v1/images/boats/significance", regions.dump());
  ASSERT_EQ(edit.status, 200) << edit.body;
  const json held = analyses(http, "boats");
  EXPECT_TRUE(holds(held, "icaz.default")) << held;
  EXPECT_TRUE(holds(held, "patch.default")) << held;
  for (const char* other : {"patch.gbvs", "seam.default", "polyfem.default", "mp.default", "icaz.gbvs"})
    EXPECT_FALSE(holds(held, other)) << held << " holds " << other;
}

// `zoomwarp analyse` adds what a store's images lack, and a second run finds nothing to add.
TEST_F(AnalysisOnDemand, AnalyseFillsInAStoreAndIsResumable) {
  const std::string file = dir_.path() + "/boats.jpg";
  {
    std::ofstream(file, std::ios::binary) << sample_;
  }
  const auto ingest = testing::run_command({testing::zoomwarp_binary(), "ingest", file, "--store", store()});
  ASSERT_EQ(ingest.exit_code, 0) << ingest.output;
  const auto first = testing::run_command({testing::zoomwarp_binary(), "analyse", "--store", store()});
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_NE(first.output.find("seam.gbvs"), std::string::npos) << first.output;
  testing::ServerProcess server(store());
  HttpClient http(server.port());
  const json held = analyses(http, "boats");
  for (const char* name : {"icaz.default", "icaz.gbvs", "lines", "seam.default", "seam.gbvs", "patch.default",
                           "patch.gbvs", "polyfem.default", "polyfem.gbvs", "mp.default", "mp.gbvs"})
    EXPECT_TRUE(holds(held, name)) << held << " lacks " << name;
  const auto again = testing::run_command({testing::zoomwarp_binary(), "analyse", "boats", "--store", store()});
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("added nothing"), std::string::npos) << again.output;
  const auto unknown = testing::run_command({testing::zoomwarp_binary(), "analyse", "nope", "--store", store()});
  EXPECT_EQ(unknown.exit_code, 1) << unknown.output;
  EXPECT_NE(unknown.output.find("nope: no such image"), std::string::npos) << unknown.output;
  EXPECT_EQ(testing::run_command({testing::zoomwarp_binary(), "analyse", "--analyses", "some", "--store", store()}).exit_code,
            2);
}

}  // namespace
}  // namespace zoomwarp
