// saliency=gbvs on the wire: significance.png shows another map, views and meshes warp by it,
// curator regions apply to it, bad values are a 400, and a damaged gbvs.bin is computed again in
// memory (the image is still served) with a warning in the log.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HttpClient;

class Gbvs : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    // Eager analyses (--analyses all): one test damages the stored GBVS map.
    server_ = new testing::ServerProcess(dir_->path() + "/store", {"--analyses", "all"});
    // 640×400: the analysis image is the image, one map pixel per image pixel.
    const std::string small = dir_->path() + "/small.png";
    testing::write_image(small, testing::resize(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"), 640, 400));
    HttpClient http(server_->port());
    for (const char* id : {"boats", "edited", "damaged"}) {
      auto r = http.request("POST", std::string("/v1/images?id=") + id, testing::read_file(small));
      ASSERT_EQ(r.status, 201) << r.body;
    }
  }
  static void TearDownTestSuite() {
    delete server_;
    delete dir_;
  }
  static std::string version_dir(const std::string& id) {
    return fs::canonical(dir_->path() + "/store/images/" + id).string();
  }

  tiles::Raster png(const std::string& path) {
    auto r = http.get(path);
    EXPECT_EQ(r.status, 200) << path << ": " << r.body;
    EXPECT_EQ(r.header("content-type"), "image/png");
    return r.status == 200 ? testing::decode_image(r.body) : tiles::Raster{};
  }

  json mesh(const std::string& query) {
    auto r = http.get("/v1/images/boats/mesh?" + query);
    EXPECT_EQ(r.status, 200) << query << ": " << r.body;
    return r.status == 200 ? json::parse(r.body) : json();
  }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
};
testing::TempDir* Gbvs::dir_ = nullptr;
testing::ServerProcess* Gbvs::server_ = nullptr;

double mean_abs_difference(const tiles::Raster& a, const tiles::Raster& b) {
  double sum = 0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) sum += std::abs(int(a.pixels[i]) - int(b.pixels[i]));
  return sum / double(a.pixels.size());
}

TEST_F(Gbvs, SignificancePngShowsTheGbvsMapWhenAskedFor) {
  const tiles::Raster by_default = png("/v1/images/boats/significance.png");
  const tiles::Raster gbvs = png("/v1/images/boats/significance.png?saliency=gbvs");
  ASSERT_EQ(gbvs.width, 640);
  ASSERT_EQ(gbvs.height, 400);
  ASSERT_EQ(by_default.pixels.size(), gbvs.pixels.size());
  EXPECT_GT(mean_abs_difference(by_default, gbvs), 10) << "another map, not the default one";
  // GBVS is smooth: a blurred 32-cell map, so neighbouring pixels are close everywhere.
  int jumps = 0;
  for (int y = 0; y < gbvs.height; ++y)
    for (int x = 1; x < gbvs.width; ++x)
      jumps += std::abs(int(gbvs.pixels[std::size_t(y) * gbvs.width + x]) - int(gbvs.pixels[std::size_t(y) * gbvs.width + x - 1])) > 8;
  EXPECT_EQ(jumps, 0);
  const auto a = http.get("/v1/images/boats/significance.png"), b = http.get("/v1/images/boats/significance.png?saliency=default"),
             c = http.get("/v1/images/boats/significance.png?saliency=gbvs");
  EXPECT_EQ(a.header("etag"), b.header("etag"));
  EXPECT_EQ(a.body, b.body);
  EXPECT_NE(a.header("etag"), c.header("etag"));
}

TEST_F(Gbvs, ViewsAndMeshesWarpByTheGbvsMap) {
  const std::string view = "zoom=0&w=360&h=640";
  const json by_default = mesh(view), gbvs = mesh(view + "&saliency=gbvs");
  // Both cuts come from one forest: the vertices they share (same source point) are compared.
  std::map<std::pair<double, double>, std::pair<double, double>> on_screen;
  for (const auto& v : by_default["vertices"]) on_screen[{v[0], v[1]}] = {v[2], v[3]};
  int shared = 0;
  double moved = 0;
  for (const auto& v : gbvs["vertices"]) {
    const auto it = on_screen.find({v[0], v[1]});
    if (it == on_screen.end()) continue;
    ++shared;
    moved = std::max(moved, std::hypot(v[2].get<double>() - it->second.first, v[3].get<double>() - it->second.second));
  }
  EXPECT_GT(shared, 100);
  EXPECT_GT(moved, 5) << "screen px: another significance, another warp";
  const auto v_default = http.get("/v1/images/boats/viewport?" + view + "&format=png"),
             v_gbvs = http.get("/v1/images/boats/viewport?" + view + "&format=png&saliency=gbvs");
  ASSERT_EQ(v_gbvs.status, 200) << v_gbvs.body;
  const tiles::Raster screen = testing::decode_image(v_gbvs.body);
  EXPECT_EQ(screen.width, 360);
  EXPECT_EQ(screen.height, 640);
  EXPECT_NE(v_default.body, v_gbvs.body);
  // Traditional zoom has no significance to use.
  EXPECT_EQ(http.get("/v1/images/boats/viewport?zoom=0.3&w=320&h=240&format=png&method=traditional").body,
            http.get("/v1/images/boats/viewport?zoom=0.3&w=320&h=240&format=png&method=traditional&saliency=gbvs").body);
}

TEST_F(Gbvs, CuratorRegionsApplyToTheGbvsMap) {
  const tiles::Raster before = png("/v1/images/edited/significance.png?saliency=gbvs");
  const json regions = {{"regions", {{{"rect", {400, 150, 160, 120}}, {"weight", 0}}}}};
  auto r = http.request("PATCH", "/v1/images/edited/significance", regions.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  const tiles::Raster after = png("/v1/images/edited/significance.png?saliency=gbvs");
  ASSERT_EQ(after.width, 640);
  EXPECT_GT(before.pixels[std::size_t(210) * 640 + 480], 0);
  EXPECT_EQ(after.pixels[std::size_t(210) * 640 + 480], 0) << "inside the region";
  EXPECT_EQ(after.pixels[std::size_t(50) * 640 + 100], before.pixels[std::size_t(50) * 640 + 100]) << "outside it";
}

TEST_F(Gbvs, AnUnknownSaliencyOrParameterIsA400) {
  // A repeated parameter is refused by the router before the route sees it (invalid_query).
  for (const auto& [path, code] : std::vector<std::pair<std::string, std::string>>{
           {"/v1/images/boats/viewport?zoom=0&w=320&h=240&saliency=bogus", "bad_request"},
           {"/v1/images/boats/mesh?zoom=0&w=320&h=240&saliency=GBVS", "bad_request"},
           {"/v1/images/boats/significance.png?saliency=bogus", "bad_request"},
           {"/v1/images/boats/significance.png?saliency=", "bad_request"},
           {"/v1/images/boats/significance.png?zoom=0", "bad_request"},
           {"/v1/images/boats/significance.png?saliency=gbvs&saliency=gbvs", "invalid_query"}}) {
    SCOPED_TRACE(path);
    auto r = http.get(path);
    EXPECT_EQ(r.status, 400);
    const json body = json::parse(r.body, nullptr, false);
    ASSERT_TRUE(body.is_object()) << r.body;
    EXPECT_EQ(body["error"]["code"], code);
    EXPECT_FALSE(body["error"]["message"].get<std::string>().empty());
  }
}

TEST_F(Gbvs, ADamagedGbvsFileIsComputedAgainInMemoryAndLogged) {
  const std::string file = version_dir("damaged") + "/gbvs.bin";
  const tiles::Raster intact = png("/v1/images/boats/significance.png?saliency=gbvs");
  std::string bytes = testing::read_file(file);
  bytes[bytes.size() / 2] ^= 0x10;
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  const tiles::Raster served = png("/v1/images/damaged/significance.png?saliency=gbvs");
  EXPECT_TRUE(served.pixels == intact.pixels) << "the same image: the same map, computed again";
  EXPECT_EQ(http.get("/v1/images/damaged/viewport?zoom=0.2&w=320&h=240&saliency=gbvs").status, 200);
  ASSERT_TRUE(server_->wait_for_log("gbvs.bin")) << server_->log();
  int warnings = 0;
  std::istringstream log(server_->log());
  for (std::string line; std::getline(log, line);) {
    const json j = json::parse(line, nullptr, false);
    warnings += j.is_object() && j.value("level", "") == "warn" && j.value("image", "") == "damaged" &&
                j.value("file", "") == "gbvs.bin";
  }
  EXPECT_EQ(warnings, 1) << "once: the engine is cached";
  EXPECT_EQ(testing::read_file(file), bytes) << "never written into a published version";
}

TEST_F(Gbvs, DegenerateShapesGetAGbvsMapAndViews) {
  for (auto [w, h] : {std::pair{1, 1}, {2, 10000}, {3000, 109}}) {
    const std::string id = "shape" + std::to_string(w) + "x" + std::to_string(h);
    SCOPED_TRACE(id);
    const std::string file = dir_->path() + "/" + id + ".png";
    testing::write_image(file, testing::test_pattern(w, h, 3));
    ASSERT_EQ(http.request("POST", "/v1/images?id=" + id, testing::read_file(file)).status, 201);
    const tiles::Raster by_default = png("/v1/images/" + id + "/significance.png");
    const tiles::Raster gbvs = png("/v1/images/" + id + "/significance.png?saliency=gbvs");
    EXPECT_EQ(gbvs.width, by_default.width);
    EXPECT_EQ(gbvs.height, by_default.height);
    for (const char* zoom : {"0", "0.5", "1"}) {
      auto r = http.get("/v1/images/" + id + "/viewport?zoom=" + zoom + "&w=360&h=640&format=png&saliency=gbvs");
      ASSERT_EQ(r.status, 200) << zoom << ": " << r.body;
      const tiles::Raster screen = testing::decode_image(r.body);
      EXPECT_EQ(screen.width, 360);
      EXPECT_EQ(screen.height, 640);
    }
    // Its stored map is read as it was written, not taken for a damaged one and made again on
    // every load (a 2×10000 image's 1×1024 map once was: its scale, width over width, is 0.5).
    std::istringstream log(server_->log());
    for (std::string line; std::getline(log, line);) {
      const json j = json::parse(line, nullptr, false);
      EXPECT_FALSE(j.is_object() && j.value("image", "") == id && j.value("level", "") != "info") << line;
    }
  }
}

}  // namespace
}  // namespace zoomwarp
