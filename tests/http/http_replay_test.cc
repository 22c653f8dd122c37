// `zoomwarp replay` against a real server: every shipped view path (tests/load/) replays without
// an error and reports sane statistics; a malformed path and an unreachable server give their exit
// codes.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>
#include <nlohmann/json.hpp>

#include "tests/support/http_client.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;

// Each client makes this many requests: a stretch of 30 actions (mesh and viewport each) from its
// own starting point, enough to meet both zooms and pans in every shipped path.
constexpr int kCount = 60;
constexpr int kClients = 4;

std::string view_path(const std::string& name) { return std::string(ZOOMWARP_VIEW_PATHS) + "/" + name; }

class Replay : public ::testing::Test {
 protected:
  // The three samples ingested through the CLI, under the ids named after their files.
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    const std::string store = dir_->path() + "/store";
    for (const char* file : {"boats_lake_sunset.jpg", "pano_grossmugl_field_4to1.png", "interior_wine_djembe_tall.jpg"}) {
      auto r = testing::run_command(
          {testing::zoomwarp_binary(), "ingest", testing::samples_dir() + "/" + file, "--store", store, "--quiet"});
      ASSERT_EQ(r.exit_code, 0) << r.output;
    }
    server_ = new testing::ServerProcess(store, {"--log-requests", "0"});
  }
  static void TearDownTestSuite() {
    delete server_;
    delete dir_;
  }

  static std::string url() { return "http://127.0.0.1:" + std::to_string(server_->port()); }

  static testing::RunResult replay(const std::vector<std::string>& args) {
    std::vector<std::string> argv = {testing::zoomwarp_binary(), "replay"};
    argv.insert(argv.end(), args.begin(), args.end());
    return testing::run_command(argv);
  }

  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
};
testing::TempDir* Replay::dir_ = nullptr;
testing::ServerProcess* Replay::server_ = nullptr;

TEST_F(Replay, ShippedPathsReplayWithoutErrors) {
  for (auto [path, image] : {std::pair{"boats_explore.jsonl", "boats_lake_sunset"},
                             {"pano_explore.jsonl", "pano_grossmugl_field_4to1"},
                             {"interior_explore.jsonl", "interior_wine_djembe_tall"}}) {
    SCOPED_TRACE(path);
    auto r = replay({view_path(path), "--image", image, "--url", url(), "--json", "--clients",
                     std::to_string(kClients), "--count", std::to_string(kCount), "--fail-on-error"});
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const json summary = json::parse(r.output, nullptr, false);
    ASSERT_TRUE(summary.is_object()) << r.output;
    EXPECT_EQ(summary["requests"], kClients * kCount);
    EXPECT_EQ(summary["errors"], 0);
    EXPECT_GT(summary["requests_per_second"].get<double>(), 0);
    for (const char* endpoint : {"mesh", "viewport"})
      for (const char* action : {"zoom", "pan"}) {
        SCOPED_TRACE(std::string(endpoint) + " " + action);
        const json& s = summary["endpoints"][endpoint][action];
        ASSERT_TRUE(s.is_object()) << r.output;
        EXPECT_GT(s["requests"].get<int>(), 0);
        EXPECT_EQ(s["errors"], 0);
        const double p50 = s["p50_ms"], p95 = s["p95_ms"], p99 = s["p99_ms"];
        EXPECT_GT(p50, 0);
        EXPECT_LE(p50, p95);
        EXPECT_LE(p95, p99);
      }
  }
}

// Every method GET /v1/methods lists replays (issue 32): its mesh and viewport, or its viewport
// alone when it has no mesh; such a method with a mesh endpoint is a usage mistake. Each method's
// analysis and its warp for the path's 480×360 screen are made on first use: the first view is
// asked for until it is ready, so that the replay measures views, not analyses.
TEST_F(Replay, EveryListedMethodReplays) {
  testing::HttpClient http(server_->port());
  const json methods = json::parse(http.get("/v1/methods").body)["methods"];
  ASSERT_GE(methods.size(), 7u);
  const std::string first_view = "?zoom=0&cx=1280&cy=800&w=480&h=360&method=";
  for (const json& m : methods) {
    const std::string name = m["name"], endpoint = m["mesh"].get<bool>() ? "both" : "viewport";
    SCOPED_TRACE(name);
    for (const std::string route : {"viewport", "mesh"}) {
      if (route == "mesh" && endpoint == "viewport") continue;
      int status = 0;
      for (int i = 0; i < 60 && (status = http.get("/v1/images/boats_lake_sunset/" + route + first_view + name).status) == 503; ++i)
        std::this_thread::sleep_for(std::chrono::seconds(1));
      ASSERT_EQ(status, 200) << route;
    }
    auto r = replay({view_path("boats_explore.jsonl"), "--image", "boats_lake_sunset", "--url", url(), "--json",
                     "--clients", "2", "--count", "10", "--method", name, "--endpoint", endpoint, "--fail-on-error"});
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const json summary = json::parse(r.output, nullptr, false);
    ASSERT_TRUE(summary.is_object()) << r.output;
    EXPECT_EQ(summary["requests"], 20);
    EXPECT_EQ(summary["errors"], 0);
    if (endpoint == "viewport") {
      r = replay({view_path("boats_explore.jsonl"), "--image", "boats_lake_sunset", "--url", url(), "--method", name});
      EXPECT_EQ(r.exit_code, 2) << r.output;
      EXPECT_NE(r.output.find("has no mesh"), std::string::npos) << r.output;
    }
  }
}

TEST_F(Replay, MalformedPathExits2NamingFileAndLine) {
  const std::string path = dir_->path() + "/bad.jsonl";
  std::ofstream(path) << R"({"action": "zoom", "zoom": 0, "cx": 1280, "cy": 800})" "\n"
                      << "# a comment, then a blank line\n\n"
                      << R"({"action": "spin", "zoom": 0.5, "cx": 1280, "cy": 800})" "\n";
  auto r = replay({path, "--image", "boats_lake_sunset", "--url", url()});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(path + ":4:"), std::string::npos) << r.output;

  // Valid lines, but made for another image: refused before any request, pointing at the line.
  r = replay({view_path("interior_explore.jsonl"), "--image", "pano_grossmugl_field_4to1", "--url", url()});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("interior_explore.jsonl:"), std::string::npos) << r.output;
}

TEST_F(Replay, UnreachableServerOrUnknownImageExits1) {
  auto r = replay({view_path("boats_explore.jsonl"), "--image", "boats_lake_sunset", "--url",
                   "http://127.0.0.1:" + std::to_string(testing::unused_loopback_port())});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("cannot connect"), std::string::npos) << r.output;
  r = replay({view_path("boats_explore.jsonl"), "--image", "nowhere", "--url", url()});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("404"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace zoomwarp
