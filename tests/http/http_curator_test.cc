// A curator's work on the wire: model files and manifests damaged on disk between two server
// runs (never a crash, never a silent loss of lines or significance edits), the limits on edits
// and screens at their edges, and face detection's state at start-up.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/core/limits.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
namespace limits = warp::limits;
using nlohmann::json;
using testing::HttpClient;

// The log lines (JSON) of `level` whose msg contains `msg` and that hold every field of `fields`.
int count_log_lines(const std::string& log, const std::string& level, const std::string& msg, const json& fields) {
  std::istringstream in(log);
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    const json j = json::parse(line, nullptr, false);
    if (!j.is_object() || j.value("level", "") != level || j.value("msg", "").find(msg) == std::string::npos) continue;
    bool all = true;
    for (const auto& [key, value] : fields.items()) all = all && j.contains(key) && j[key] == value;
    n += all;
  }
  return n;
}

std::string version_dir(const std::string& store, const std::string& id) {
  return fs::canonical(store + "/images/" + id).string();
}

void truncate_file(const std::string& path) {
  const std::string bytes = testing::read_file(path);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes.substr(0, bytes.size() / 2);
}

void flip_middle(const std::string& path) {
  std::string bytes = testing::read_file(path);
  for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 4; ++i) bytes[i] = char(~bytes[i]);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

void garbage(const std::string& path) { std::ofstream(path, std::ios::trunc) << "{\"lines\": [[1, 2"; }

struct Case {
  std::string id;
  std::string file;  // in the version's folder
  void (*damage)(const std::string&);
};

const std::vector<Case>& model_cases() {
  static const std::vector<Case> cases = {
      {"sig-truncated", "significance.bin", truncate_file},
      {"sig-flipped", "significance.bin", flip_middle},
      {"sig-deleted", "significance.bin", [](const std::string& p) { fs::remove(p); }},
      {"model-truncated", "warp_model.bin", truncate_file},
      {"model-flipped", "warp_model.bin", flip_middle},
      {"model-deleted", "warp_model.bin", [](const std::string& p) { fs::remove(p); }},
      {"json-truncated", "warp.json", truncate_file},
      {"json-garbage", "warp.json", garbage},
      {"json-deleted", "warp.json", [](const std::string& p) { fs::remove(p); }},
      {"restore-json", "warp.json", [](const std::string& p) { fs::remove(p); }},
      {"manifest-garbage", "manifest.json", garbage},
      {"manifest-truncated", "manifest.json", truncate_file},
      {"manifest-deleted", "manifest.json", [](const std::string& p) { fs::remove(p); }},
  };
  return cases;
}

const json kLines = {{"lines", {{20, 300, 620, 300}}}};
const json kRegions = {{"regions", {{{"rect", {400, 40, 160, 120}}, {"weight", 1}}, {{"rect", {40, 40, 160, 120}}, {"weight", 0}}}}};

// Every case's image is uploaded and edited (a line, a region marked important and one marked
// unimportant), the server stops, one file of each is damaged, and a new server serves them.
class DamagedStore : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    const std::string image = dir_->path() + "/small.png";
    const tiles::Raster boats = testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg");
    testing::write_image(image, testing::resize(boats, 640, 400));
    {
      testing::ServerProcess first(store());
      HttpClient http(first.port());
      for (const Case& c : model_cases()) {
        ASSERT_EQ(http.request("POST", "/v1/images?id=" + c.id, testing::read_file(image)).status, 201);
        ASSERT_EQ(http.request("PUT", "/v1/images/" + c.id + "/lines", kLines.dump()).status, 200);
        ASSERT_EQ(http.request("PATCH", "/v1/images/" + c.id + "/significance", kRegions.dump()).status, 200);
      }
      ASSERT_EQ(first.terminate(), 0);
    }
    repaired_json_ = new std::string(testing::read_file(version_dir(store(), "restore-json") + "/warp.json"));
    for (const Case& c : model_cases()) c.damage(version_dir(store(), c.id) + "/" + c.file);
    server_ = new testing::ServerProcess(store(), {"--failure-cache-ms", "3000"});
  }
  static void TearDownTestSuite() {
    delete server_;
    delete repaired_json_;
    delete dir_;
  }
  static std::string store() { return dir_->path() + "/store"; }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
  static std::string* repaired_json_;  // restore-json's warp.json, to put back
};
testing::TempDir* DamagedStore::dir_ = nullptr;
testing::ServerProcess* DamagedStore::server_ = nullptr;
std::string* DamagedStore::repaired_json_ = nullptr;

TEST_F(DamagedStore, ADamagedBinaryModelFileIsRebuiltWithTheLinesAndEditsAndLogged) {
  for (const Case& c : model_cases()) {
    if (c.file != "significance.bin" && c.file != "warp_model.bin") continue;
    SCOPED_TRACE(c.id);
    const std::string base = "/v1/images/" + c.id;
    auto lines = http.get(base + "/lines");
    ASSERT_EQ(lines.status, 200) << lines.body;
    EXPECT_EQ(json::parse(lines.body)["lines"], kLines["lines"]);
    auto png = http.get(base + "/significance.png");
    ASSERT_EQ(png.status, 200) << png.body;
    const tiles::Raster map = testing::decode_image(png.body);
    ASSERT_EQ(map.width, 640);  // the image is ≤ 1024 px: one map pixel per image pixel
    EXPECT_EQ(map.pixels[std::size_t(100 * map.width + 480) * map.channels], 255) << "the region marked important";
    EXPECT_EQ(map.pixels[std::size_t(100 * map.width + 120) * map.channels], 0) << "the region marked unimportant";
    EXPECT_EQ(http.get(base + "/viewport?zoom=0.5&w=320&h=320").status, 200);
    EXPECT_EQ(count_log_lines(server_->log(), "warn", "rebuilt with the curator's lines and edits",
                              {{"image", c.id}, {"file", c.file}}),
              1);
  }
}

TEST_F(DamagedStore, AnEditOnARebuiltModelKeepsEveryEarlierEdit) {
  const std::string base = "/v1/images/model-flipped";
  const json more = {{"regions", {{{"rect", {40, 250, 100, 100}}, {"weight", 1}}}}};
  ASSERT_EQ(http.request("PATCH", base + "/significance", more.dump()).status, 200);
  const tiles::Raster map = testing::decode_image(http.get(base + "/significance.png").body);
  EXPECT_EQ(map.pixels[std::size_t(100 * map.width + 480) * map.channels], 255);
  EXPECT_EQ(map.pixels[std::size_t(100 * map.width + 120) * map.channels], 0);
  EXPECT_EQ(map.pixels[std::size_t(300 * map.width + 90) * map.channels], 255) << "the new region";
  EXPECT_EQ(json::parse(http.get(base + "/lines").body)["lines"], kLines["lines"]);
}

TEST_F(DamagedStore, ADamagedWarpJsonAnswers500OnWarpRoutesAndTilesStillWork) {
  for (const Case& c : model_cases()) {
    if (c.id.rfind("json-", 0) != 0) continue;
    SCOPED_TRACE(c.id);
    const std::string base = "/v1/images/" + c.id;
    const std::string etag = http.get(base).header("etag");
    for (const std::string route : {"/viewport?zoom=0&w=320&h=320", "/mesh?zoom=0&w=320&h=320", "/lines", "/significance.png"}) {
      auto r = http.get(base + route);
      EXPECT_EQ(r.status, 500) << route;
      const json body = json::parse(r.body, nullptr, false);
      ASSERT_TRUE(body.is_object()) << r.body;
      EXPECT_EQ(body["error"]["code"], "model_damaged");
      const std::string message = body["error"]["message"];
      EXPECT_NE(message.find(c.id), std::string::npos) << message;
      EXPECT_EQ(message.find(dir_->path()), std::string::npos) << "no path in the answer: " << message;
    }
    auto put = http.request("PUT", base + "/lines", R"({"lines": []})");
    EXPECT_EQ(put.status, 500) << put.body;
    EXPECT_EQ(http.get(base).header("etag"), etag) << "nothing was published";
    EXPECT_GE(count_log_lines(server_->log(), "error", "curator edits unreadable", {{"image", c.id}, {"file", c.file}}), 1);
    EXPECT_EQ(http.get("/dzi/" + c.id + ".dzi").status, 200);
    EXPECT_EQ(http.get("/dzi/" + c.id + "_files/9/0_0.jpg").status, 200);
    EXPECT_EQ(http.get("/iiif/3/" + c.id + "/info.json").status, 200);
  }
}

// Failures are remembered for --failure-cache-ms only: once an operator restores warp.json, the
// request is served as soon as the Retry-After of the remembered failure has passed.
TEST_F(DamagedStore, ARestoredWarpJsonIsPickedUpWithoutARestart) {
  const std::string base = "/v1/images/restore-json";
  ASSERT_EQ(http.get(base + "/lines").status, 500);
  std::ofstream(version_dir(store(), "restore-json") + "/warp.json", std::ios::trunc) << *repaired_json_;
  const auto remembered = http.get(base + "/lines");
  ASSERT_EQ(remembered.status, 500);
  const int retry_after = std::atoi(remembered.header("retry-after").c_str());
  ASSERT_GE(retry_after, 1);
  std::this_thread::sleep_for(std::chrono::seconds(retry_after) + std::chrono::milliseconds(100));
  auto r = http.get(base + "/lines");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(json::parse(r.body)["lines"], kLines["lines"]);
}

TEST_F(DamagedStore, AnImageWithADamagedManifestAnswers500AndCanBeDeleted) {
  for (const Case& c : model_cases()) {
    if (c.file != "manifest.json") continue;
    SCOPED_TRACE(c.id);
    const std::string base = "/v1/images/" + c.id;
    for (const std::string route : {"", "/viewport?zoom=0&w=320&h=320", "/lines"}) {
      auto r = http.get(base + route);
      EXPECT_EQ(r.status, 500) << route;
      EXPECT_EQ(json::parse(r.body, nullptr, false)["error"]["code"], "image_damaged") << r.body;
    }
    EXPECT_EQ(http.get("/dzi/" + c.id + ".dzi").status, 500);
    EXPECT_EQ(http.request("DELETE", base).status, 204);
    EXPECT_EQ(http.get(base).status, 404);
    EXPECT_EQ(http.request("DELETE", base).status, 404);
  }
  const std::string list = http.get("/v1/images").body;
  EXPECT_EQ(list.find("manifest-"), std::string::npos) << list;
}

// The limits of warp/core/limits.h at their edges: the largest edit accepted (2xx), one more refused
// with 413 and the limit's code, nothing published.
class Limits : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    server_ = new testing::ServerProcess(dir_->path() + "/store");
    HttpClient http(server_->port());
    ASSERT_EQ(http.request("POST", "/v1/images?id=b",
                           testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg")).status, 201);
  }
  static void TearDownTestSuite() {
    delete server_;
    delete dir_;
  }

  std::string etag() { return http.get("/v1/images/b").header("etag"); }

  // Sends the edit expecting it refused with 413 `code`, and the image unchanged.
  void expect_refused(const std::string& method, const std::string& what, const json& body, const std::string& code) {
    const std::string before = etag();
    auto r = http.request(method, "/v1/images/b/" + what, body.dump());
    EXPECT_EQ(r.status, 413) << r.body;
    EXPECT_EQ(json::parse(r.body, nullptr, false)["error"]["code"], code) << r.body;
    EXPECT_EQ(etag(), before) << "nothing was published";
  }

  static json rects(int n) {
    json regions = json::array();
    for (int k = 0; k < n; ++k) regions.push_back({{"rect", {40 * (k % 60), 25 * (k / 60), 30, 20}}, {"weight", 1}});
    return {{"regions", regions}};
  }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
};
testing::TempDir* Limits::dir_ = nullptr;
testing::ServerProcess* Limits::server_ = nullptr;

TEST_F(Limits, LinesTheirNumberAndTotalLength) {
  constexpr double W = 2560, H = 1600;
  // kMaxLines horizontal lines in two columns, together exactly the longest total allowed.
  const double length = limits::kMaxTotalLineLength * std::max(W, H) / limits::kMaxLines;
  const int rows = (limits::kMaxLines + 1) / 2;
  ASSERT_LE(2 * length + 200, W) << "the test's layout needs shorter lines";
  auto lines = [&](int n, double extra) {
    json out = json::array();
    for (int k = 0; k < n; ++k) {
      const double x = k % 2 ? W - 50 - length : 50, y = 20 + (H - 40) * (k / 2) / rows;
      out.push_back({x, y, x + length + (k == 0 ? extra : 0), y});
    }
    return json{{"lines", out}};
  };
  auto ok = http.request("PUT", "/v1/images/b/lines", lines(limits::kMaxLines, 0).dump());
  EXPECT_EQ(ok.status, 200) << ok.body;
  EXPECT_EQ(json::parse(http.get("/v1/images/b/lines").body)["lines"].size(), std::size_t(limits::kMaxLines));
  expect_refused("PUT", "lines", lines(limits::kMaxLines + 1, 0), "too_many_lines");
  expect_refused("PUT", "lines", lines(limits::kMaxLines, 1), "lines_too_long");
}

TEST_F(Limits, RegionsPerEditPointsPerPolygonAndRegionsKept) {
  ASSERT_GE(limits::kMaxStoredRegions, limits::kMaxRegionsPerEdit);
  expect_refused("PATCH", "significance", rects(limits::kMaxRegionsPerEdit + 1), "too_many_regions");
  auto polygon = [](int n) {
    json points = json::array();
    for (int k = 0; k < n; ++k)
      points.push_back({1280 + 500 * std::cos(2 * M_PI * k / n), 800 + 500 * std::sin(2 * M_PI * k / n)});
    return json{{"regions", {{{"polygon", points}, {"weight", 0.5}}}}};
  };
  expect_refused("PATCH", "significance", polygon(limits::kMaxPolygonPoints + 1), "too_many_points");
  auto r = http.request("PATCH", "/v1/images/b/significance", polygon(limits::kMaxPolygonPoints).dump());
  ASSERT_EQ(r.status, 200) << r.body;

  // Fill the image up to kMaxStoredRegions with edits of the largest size; time those.
  int kept = 1;
  double slowest_s = 0;
  while (kept < limits::kMaxStoredRegions) {
    const int n = std::min(limits::kMaxRegionsPerEdit, limits::kMaxStoredRegions - kept);
    const auto t0 = std::chrono::steady_clock::now();
    r = http.request("PATCH", "/v1/images/b/significance", rects(n).dump());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_EQ(r.status, 200) << r.body;
    if (n == limits::kMaxRegionsPerEdit) slowest_s = std::max(slowest_s, s);
    kept += n;
  }
  std::printf("[ figure ] slowest PATCH of %d rectangles: %.3f s\n", limits::kMaxRegionsPerEdit, slowest_s);
  expect_refused("PATCH", "significance", rects(1), "too_many_stored_regions");
  EXPECT_EQ(http.request("PUT", "/v1/images/b/lines", R"({"lines": []})").status, 200) << "lines stay editable";
}

TEST_F(Limits, ScreenSize) {
  const int side = limits::kMaxScreenSide;
  const int h = int(std::min<long long>(side, limits::kMaxScreenPixels / side));
  auto ok = http.get("/v1/images/b/mesh?zoom=1&method=traditional&w=" + std::to_string(side) + "&h=" + std::to_string(h));
  EXPECT_EQ(ok.status, 200) << ok.body;
  for (const std::string& q : {"w=" + std::to_string(side + 1) + "&h=16", "w=16&h=" + std::to_string(side + 1)}) {
    auto r = http.get("/v1/images/b/mesh?zoom=1&method=traditional&" + q);
    EXPECT_EQ(r.status, 400) << q;
    EXPECT_NE(json::parse(r.body, nullptr, false)["error"]["message"].get<std::string>().find(std::to_string(side)),
              std::string::npos) << r.body;
  }
  if (h < side) {  // the pixel count binds before the sides do
    auto r = http.get("/v1/images/b/mesh?zoom=1&method=traditional&w=" + std::to_string(side) + "&h=" + std::to_string(h + 1));
    EXPECT_EQ(r.status, 400) << r.body;
  }
}

TEST(FaceCascade, AMissingCascadeIsLoggedAtStartAndShownByReadyzWhichStaysReady) {
  testing::TempDir dir;
  testing::ServerProcess server(dir.path() + "/store", {"--face-cascade", dir.path() + "/no-such-cascade.xml"});
  HttpClient http(server.port());
  auto r = http.get("/readyz");
  EXPECT_EQ(r.status, 200) << r.body;
  const json j = json::parse(r.body);
  EXPECT_EQ(j["status"], "ready");
  EXPECT_EQ(j["checks"]["face_detection"], "off: cascade file not found");
  EXPECT_EQ(count_log_lines(server.log(), "warn", "face detection is off", {{"problem", "cascade file not found"}}), 1);

  const std::string garbage_cascade = dir.path() + "/garbage.xml";
  std::ofstream(garbage_cascade) << "not a cascade";
  const auto ingest = testing::run_command({testing::zoomwarp_binary(), "ingest", "--store", dir.path() + "/store2",
                                            "--face-cascade", garbage_cascade,
                                            testing::samples_dir() + "/boats_lake_sunset.jpg"});
  EXPECT_EQ(ingest.exit_code, 0) << ingest.output;
  EXPECT_NE(ingest.output.find("cascade file does not load"), std::string::npos) << ingest.output;
}

}  // namespace
}  // namespace zoomwarp
