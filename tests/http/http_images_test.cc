// /v1/images over a real server: upload, describe, list, delete, re-ingest while serving,
// restart persistence, an ingest killed half-way, and every way an upload or an id can be bad.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HttpClient;
using testing::ServerProcess;
using testing::TempDir;

std::string sample(const std::string& name) { return testing::read_file(testing::samples_dir() + "/" + name); }

void expect_json_error(const testing::HttpResponse& r, int status, const std::string& code = "") {
  EXPECT_EQ(r.status, status) << r.body;
  EXPECT_EQ(r.header("content-type"), "application/json");
  auto j = json::parse(r.body, nullptr, false);
  ASSERT_TRUE(j.is_object()) << r.body;
  ASSERT_TRUE(j.contains("error")) << r.body;
  EXPECT_TRUE(j["error"]["message"].is_string());
  if (!code.empty()) {
    EXPECT_EQ(j["error"]["code"], code) << r.body;
  }
}

// Nothing half-made is left: no staging folders, no versions beyond those of published images.
void expect_store_clean(const std::string& store, std::size_t published) {
  std::size_t staging = 0, versions = 0;
  for (auto& e : fs::directory_iterator(store + "/staging")) { (void)e; ++staging; }
  for (auto& e : fs::directory_iterator(store + "/versions")) { (void)e; ++versions; }
  EXPECT_EQ(staging, 0u);
  EXPECT_EQ(versions, published);
}

TEST(Images, UploadDescribeListDelete) {
  TempDir dir;
  ServerProcess server(dir.path() + "/store");
  HttpClient http(server.port());

  auto up = http.request("POST", "/v1/images?id=boats", sample("boats_lake_sunset.jpg"),
                         {{"Content-Type", "image/jpeg"}});
  ASSERT_EQ(up.status, 201) << up.body;
  EXPECT_EQ(up.header("location"), "/v1/images/boats");
  auto created = json::parse(up.body);
  EXPECT_EQ(created["id"], "boats");

  auto got = http.get("/v1/images/boats");
  ASSERT_EQ(got.status, 200);
  auto j = json::parse(got.body);
  EXPECT_EQ(j["id"], "boats");
  EXPECT_EQ(j["width"], 2560);
  EXPECT_EQ(j["height"], 1600);
  EXPECT_EQ(j["levels"], 13);
  EXPECT_EQ(j["tile_size"], 256);
  EXPECT_EQ(j["status"], "ready");
  EXPECT_EQ(j["version"], created["version"]);

  auto list = json::parse(http.get("/v1/images").body);
  ASSERT_EQ(list["images"].size(), 1u);
  EXPECT_EQ(list["images"][0]["id"], "boats");

  EXPECT_EQ(http.request("DELETE", "/v1/images/boats").status, 204);
  expect_json_error(http.get("/v1/images/boats"), 404, "image_not_found");
  expect_json_error(http.get("/dzi/boats.dzi"), 404);
  expect_json_error(http.request("DELETE", "/v1/images/boats"), 404);
  EXPECT_TRUE(json::parse(http.get("/v1/images").body)["images"].empty());
}

TEST(Images, UploadWithoutIdIsNamedByContent) {
  TempDir dir;
  ServerProcess server(dir.path() + "/store");
  HttpClient http(server.port());
  auto a = http.request("POST", "/v1/images", sample("pano_grossmugl_field_4to1.png"));
  auto b = http.request("POST", "/v1/images", sample("pano_grossmugl_field_4to1.png"));
  ASSERT_EQ(a.status, 201) << a.body;
  const std::string id = json::parse(a.body)["id"];
  EXPECT_EQ(id.rfind("img-", 0), 0u);
  EXPECT_EQ(json::parse(b.body)["id"], id);
  auto info = json::parse(http.get("/v1/images/" + id).body);
  EXPECT_EQ(info["width"], 2048);
  EXPECT_EQ(info["channels"], 4);
}

TEST(Images, BadUploadsAreRefusedAndLeaveNothing) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  ServerProcess server(store, {"--max-upload", "1M", "--max-pixels", "5000000"});
  HttpClient http(server.port());
  const std::string jpeg = sample("boats_lake_sunset.jpg");        // 4.1 MP, 633 KB
  const std::string tall = sample("interior_wine_djembe_tall.jpg"); // 9.8 MP, 522 KB

  expect_json_error(http.request("POST", "/v1/images?id=x", jpeg.substr(0, jpeg.size() / 2)), 422, "corrupt_image");
  expect_json_error(http.request("POST", "/v1/images?id=x", "GIF89a" + std::string(100, '\0')), 415);
  expect_json_error(http.request("POST", "/v1/images?id=x", "just some text"), 415);
  expect_json_error(http.request("POST", "/v1/images?id=x", ""), 400, "empty_body");
  expect_json_error(http.request("POST", "/v1/images?id=x", tall), 413, "image_too_large");
  for (const char* id : {"..", "..%2Fetc", "a%2Fb", "a%00b", "-x", "x%20y"})
    EXPECT_EQ(http.request("POST", std::string("/v1/images?id=") + id, jpeg).status, 400) << id;
  expect_json_error(http.request("POST", "/v1/images?id=" + std::string(129, 'a'), jpeg), 400, "invalid_id");
  expect_json_error(http.request("POST", "/v1/images?id=x&colour=red", jpeg), 400, "invalid_query");

  // Over the byte limit: refused from Content-Length, before the body is read.
  HttpClient fresh(server.port());
  std::string big = sample("lake_hill_reflection.jpg");
  if (big.size() < 2'000'000) big += std::string(2'000'000, '\0');
  expect_json_error(fresh.request("POST", "/v1/images?id=big", big), 413, "upload_too_large");

  expect_store_clean(store, 0);
  EXPECT_TRUE(json::parse(http.get("/v1/images").body)["images"].empty());
  // The server is still fine.
  EXPECT_EQ(http.request("POST", "/v1/images?id=ok", jpeg).status, 201);
  expect_store_clean(store, 1);
}

TEST(Images, BadIdsInPaths) {
  TempDir dir;
  ServerProcess server(dir.path() + "/store");
  HttpClient http(server.port());
  for (const std::string& path : std::vector<std::string>{"/v1/images/..", "/v1/images/..%2F..%2Fetc%2Fpasswd", "/v1/images/a%00b", "/v1/images/.hidden",
        "/dzi/..%2Fx.dzi", "/iiif/3/..%2F..%2Fetc/info.json", "/v1/images/" + std::string(200, 'a')})
    EXPECT_EQ(http.get(path).status, 400) << path;
  expect_json_error(http.get("/v1/images/a%zz"), 400, "invalid_path");
  expect_json_error(http.get("/v1/images/nope"), 404, "image_not_found");
  expect_json_error(http.get("/iiif/3/nope/info.json"), 404);
  expect_json_error(http.get("/nowhere"), 404, "not_found");
  expect_json_error(http.request("PUT", "/v1/images/x"), 405);
}

// A picture's fingerprint at any size: the mean colour of each of kGrid × kGrid equal cells (a
// pixel counts in the cell holding its centre), RGB.
constexpr int kGrid = 8;
std::vector<double> cell_means(const tiles::Raster& r) {
  std::vector<double> sum(kGrid * kGrid * 3, 0), count(kGrid * kGrid, 0);
  for (int y = 0; y < r.height; ++y) {
    const int cy = int((y + 0.5) * kGrid / r.height);
    const std::uint8_t* row = r.row(y);
    for (int x = 0; x < r.width; ++x) {
      const int cell = cy * kGrid + int((x + 0.5) * kGrid / r.width);
      for (int c = 0; c < 3; ++c) sum[cell * 3 + c] += row[x * r.channels + std::min(c, r.channels - 1)];
      ++count[cell];
    }
  }
  for (std::size_t i = 0; i < sum.size(); ++i) sum[i] /= count[i / 3];
  return sum;
}

// Root mean square difference of two fingerprints, in 8-bit levels.
double distance(const std::vector<double>& a, const std::vector<double>& b) {
  double se = 0;
  for (std::size_t i = 0; i < a.size(); ++i) se += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(se / a.size());
}

// One published version's picture, as a reader may be answered with it: its size and its
// fingerprint, from the source file, independently of the server (OpenImageIO's decoder).
struct Version {
  std::string file;
  int width = 0, height = 0;  // the source's
  std::vector<double> means;

  explicit Version(const std::string& name) : file(name) {
    const tiles::Raster source = testing::load_image(testing::samples_dir() + "/" + name);
    width = source.width, height = source.height, means = cell_means(source);
  }
  // Whether `shown`, the answer to full/!W,H, is this picture: within 1 px of the size IIIF's !W,H
  // gives it (the largest that fits, aspect kept), and its cells' colours the source's.
  bool shows(const tiles::Raster& shown, int box_w, int box_h, double* off) const {
    const double scale = std::min(double(box_w) / width, double(box_h) / height);
    *off = distance(cell_means(shown), means);
    return std::abs(shown.width - width * scale) <= 1 && std::abs(shown.height - height * scale) <= 1 &&
           *off <= kMaxDistance;
  }
  // Levels. Measured: answers lie at most 3.6 levels off their own picture and 63 off the other
  // one; an answer mirrored, 33 off its own.
  static constexpr double kMaxDistance = 8;
};

// A reader keeps fetching IIIF images while the same id is re-ingested with other images; every
// answer is a whole, valid image of one version or the other: the size and the cells' colours of
// one of the two pictures.
TEST(Images, ReingestWhileServingAndConcurrentIngests) {
  // The two pictures, read while the server starts and ingests the first.
  auto reading = std::async(std::launch::async, [] {
    return std::pair<Version, Version>{Version("boats_lake_sunset.jpg"), Version("interior_wine_djembe_tall.jpg")};
  });
  TempDir dir;
  ServerProcess server(dir.path() + "/store", {"--ingest-workers", "2"});
  HttpClient http(server.port());
  ASSERT_EQ(http.request("POST", "/v1/images?id=live", sample("boats_lake_sunset.jpg")).status, 201);
  const auto pictures = reading.get();
  const Version &boats = pictures.first, &interior = pictures.second;

  std::atomic<bool> stop{false};
  std::atomic<int> reads{0}, failures{0}, boats_seen{0}, interior_seen{0};
  std::mutex figures;
  double worst_own = 0, closest_other = std::numeric_limits<double>::infinity();  // fingerprint distances, levels
  std::vector<std::thread> readers;
  for (int t = 0; t < 2; ++t)
    readers.emplace_back([&, t] {
      HttpClient c(server.port());
      for (int i = 0; !stop; ++i) {
        const int box_w = 100 + (i * 7 + t) % 300, box_h = 300;
        const std::string target = "/iiif/3/live/full/!" + std::to_string(box_w) + "," + std::to_string(box_h) + "/0/default.jpg";
        auto r = c.get(target);
        if (r.status != 200) {
          if (failures++ < 5) ADD_FAILURE() << target << ": " << r.status;
          continue;
        }
        try {
          const tiles::Raster shown = testing::decode_image(r.body);
          double off_boats = 0, off_interior = 0;
          const bool is_boats = boats.shows(shown, box_w, box_h, &off_boats);
          const bool is_interior = interior.shows(shown, box_w, box_h, &off_interior);
          {
            std::lock_guard lock(figures);
            worst_own = std::max(worst_own, is_boats ? off_boats : is_interior ? off_interior : 0);
            if (is_boats || is_interior) closest_other = std::min(closest_other, is_boats ? off_interior : off_boats);
          }
          if (is_boats) ++boats_seen;
          else if (is_interior) ++interior_seen;
          else if (failures++ < 5) {
            ADD_FAILURE() << target << ": " << shown.width << "x" << shown.height
                          << " is neither version's picture (colours off the boats' by " << off_boats
                          << " levels, the interior's by " << off_interior << ")";
          }
          ++reads;
        } catch (const std::exception& e) {
          if (failures++ < 5) ADD_FAILURE() << target << ": " << e.what();
        }
      }
    });
  std::thread other([&] {
    HttpClient c(server.port());
    for (int i = 0; i < 2; ++i)
      EXPECT_EQ(c.request("POST", "/v1/images?id=other" + std::to_string(i), sample("pano_grossmugl_field_4to1.png")).status, 201);
  });
  for (const Version* v : {&interior, &boats, &interior})
    EXPECT_EQ(http.request("POST", "/v1/images?id=live", sample(v->file)).status, 201);
  other.join();
  stop = true;
  for (auto& t : readers) t.join();
  EXPECT_EQ(failures.load(), 0) << "(the first 5 reported above)";
  EXPECT_GT(reads.load(), 10);
  std::printf("[ reingest ] %d answers: %d the boats, %d the interior; colours off their own picture's by at most "
              "%.1f levels, off the other's by at least %.1f\n",
              reads.load(), boats_seen.load(), interior_seen.load(), worst_own, closest_other);
  auto j = json::parse(http.get("/v1/images/live").body);
  EXPECT_EQ(j["width"], 2560);
  EXPECT_EQ(j["height"], 3837);
  EXPECT_EQ(json::parse(http.get("/v1/images").body)["images"].size(), 3u);
}

// Two replicas sharing a store: a tile the second one has served (and cached) stops being served
// once the first deletes the image, and the re-ingested image replaces it, each within the second
// replica's --store-recheck-ms; the first, which made the change, answers accordingly at once.
TEST(Images, ReplicasSeeEachOthersDeleteAndReingest) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  constexpr int kRecheckMs = 200;
  ServerProcess writer(store), reader(store, {"--store-recheck-ms", std::to_string(kRecheckMs)});
  HttpClient w(writer.port()), r(reader.port());
  const std::string tile = "/dzi/shared_files/8/0_0.jpg";
  auto wait_recheck = [] { std::this_thread::sleep_for(std::chrono::milliseconds(kRecheckMs + 50)); };

  ASSERT_EQ(w.request("POST", "/v1/images?id=shared", sample("boats_lake_sunset.jpg")).status, 201);
  auto first = r.get(tile);
  ASSERT_EQ(first.status, 200);
  ASSERT_EQ(r.get(tile).status, 200);  // now a response-cache hit

  ASSERT_EQ(w.request("DELETE", "/v1/images/shared").status, 204);
  EXPECT_EQ(w.get(tile).status, 404);
  wait_recheck();
  EXPECT_EQ(r.get(tile).status, 404);

  ASSERT_EQ(w.request("POST", "/v1/images?id=shared", sample("pano_grossmugl_field_4to1.png")).status, 201);
  auto replaced = w.get(tile);
  ASSERT_EQ(replaced.status, 200);
  EXPECT_NE(replaced.body, first.body);
  wait_recheck();
  auto seen = r.get(tile);
  EXPECT_EQ(seen.status, 200);
  EXPECT_EQ(seen.body, replaced.body);
  EXPECT_EQ(seen.header("etag"), replaced.header("etag"));
}

TEST(Images, RestartedServerServesEveryPublishedImage) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  // One image through the CLI, one through HTTP.
  auto cli = testing::run_command({testing::zoomwarp_binary(), "ingest", testing::samples_dir() + "/boats_lake_sunset.jpg",
                                   "--store", store, "--quiet"});
  ASSERT_EQ(cli.exit_code, 0) << cli.output;
  EXPECT_EQ(cli.output, "boats_lake_sunset\n");
  std::string tile_before;
  {
    ServerProcess server(store);
    HttpClient http(server.port());
    ASSERT_EQ(http.request("POST", "/v1/images?id=pano", sample("pano_grossmugl_field_4to1.png")).status, 201);
    tile_before = http.get("/dzi/boats_lake_sunset_files/11/1_1.png").body;
    EXPECT_EQ(server.terminate(), 0) << "SIGTERM exits 0";
  }
  ServerProcess again(store);
  HttpClient http(again.port());
  auto list = json::parse(http.get("/v1/images").body);
  ASSERT_EQ(list["images"].size(), 2u);
  EXPECT_EQ(http.get("/dzi/boats_lake_sunset_files/11/1_1.png").body, tile_before);
  EXPECT_EQ(http.get("/dzi/pano.dzi").status, 200);
}

TEST(IngestCli, ExitCodesAndMessages) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  const std::string bin = testing::zoomwarp_binary();
  auto help = testing::run_command({bin, "ingest", "--help"});
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("ZOOMWARP_STORE"), std::string::npos);

  const std::string text = dir.path() + "/notes.txt";
  std::ofstream(text) << "not an image";
  auto r = testing::run_command({bin, "ingest", text, "--store", store});
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("unsupported"), std::string::npos);
  EXPECT_EQ(testing::run_command({bin, "ingest", dir.path() + "/missing.jpg", "--store", store}).exit_code, 2);
  EXPECT_EQ(testing::run_command({bin, "ingest", testing::samples_dir() + "/boats_lake_sunset.jpg", "--store", store,
                                  "--id", "../x"}).exit_code, 2);
  EXPECT_EQ(testing::run_command({bin, "ingest", testing::samples_dir() + "/boats_lake_sunset.jpg", "--store", store,
                                  "--max-pixels", "1000"}).exit_code, 4);
  EXPECT_EQ(testing::run_command({bin, "ingest", "--bogus"}).exit_code, 2);
  expect_store_clean(store, 0);
  // Bad tile settings are refused before the store is even made.
  const std::string untouched = dir.path() + "/untouched";
  for (const std::vector<std::string>& bad : {std::vector<std::string>{"--tile-quality", "0"}, {"--tile-quality", "101"},
                                              {"--tile-quality", "high"}, {"--tile-compression", "jpeg:90"}}) {
    std::vector<std::string> argv = {bin, "ingest", testing::samples_dir() + "/boats_lake_sunset.jpg", "--store", untouched};
    argv.insert(argv.end(), bad.begin(), bad.end());
    const auto refused = testing::run_command(argv);
    EXPECT_EQ(refused.exit_code, 2) << bad[0] << " " << bad[1];
    EXPECT_NE(refused.output.find(bad[0]), std::string::npos) << refused.output;
  }
  EXPECT_FALSE(fs::exists(untouched));
}

// The staging folder of process `pid` (HOST.PID.RANDOM), or "".
std::string staging_dir_of(const std::string& store, pid_t pid) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(store + "/staging", ec))
    if (e.path().filename().string().find("." + std::to_string(pid) + ".") != std::string::npos) return e.path().string();
  return "";
}

// Whether a pyramid level in `dir` has data in it yet.
bool has_level_data(const std::string& dir) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("level_", 0) == 0 && fs::file_size(e.path(), ec) > 0 && !ec) return true;
  }
  return false;
}

// `zoomwarp ingest` SIGKILLed half-way (no chance to clean up) leaves its staging folder behind and
// nothing else: a server sharing the store never lists or serves the image; the folder stays until
// the next server start, which removes it; then the same id ingests fine, and the server that was
// running all along serves the image published by that other process at once, without a restart.
TEST(Images, IngestKilledMidwayIsNeverServedAndIsCleanedUpAtStart) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  const std::string source = dir.path() + "/big.jpg";
  testing::write_image(source, testing::test_pattern(6000, 6000, 3));  // 36 MP: seconds to ingest
  ServerProcess running(store);
  HttpClient http(running.port());
  ASSERT_EQ(http.get("/v1/images/big").status, 404);
  const std::vector<std::string> ingest = {testing::zoomwarp_binary(), "ingest", source, "--store", store, "--id", "big", "--quiet"};

  const pid_t pid = testing::spawn_quietly(ingest);
  ASSERT_GT(pid, 0);
  std::string staging;
  bool exited = false;
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    staging = staging_dir_of(store, pid);
    if (!staging.empty() && has_level_data(staging)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!exited) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
  }
  ASSERT_FALSE(exited) << "the ingest finished (status " << status << ") before it could be killed mid-way";
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
  ASSERT_FALSE(staging.empty()) << "no staging folder with pyramid data appeared within 60 s";

  // The partial image is nowhere to be seen, through any route.
  EXPECT_TRUE(json::parse(http.get("/v1/images").body)["images"].empty());
  expect_json_error(http.get("/v1/images/big"), 404, "image_not_found");
  EXPECT_EQ(http.get("/dzi/big.dzi").status, 404);
  EXPECT_EQ(http.get("/iiif/3/big/info.json").status, 404);
  EXPECT_EQ(http.get("/v1/images/big/viewport?zoom=0&cx=10&cy=10&w=64&h=64").status, 404);
  EXPECT_FALSE(fs::exists(store + "/images/big"));
  EXPECT_TRUE(fs::is_empty(store + "/versions"));
  // Its staging folder stays (the running server collects garbage only every minute)...
  EXPECT_TRUE(has_level_data(staging)) << staging;

  // ...until a server starts on the store: it removes the dead process's folder before listening.
  {
    ServerProcess restarted(store);
    EXPECT_FALSE(fs::exists(staging)) << staging;
    EXPECT_NE(restarted.log().find("\"gc_removed\":1"), std::string::npos) << restarted.log();
    expect_store_clean(store, 0);
    EXPECT_EQ(HttpClient(restarted.port()).get("/v1/images/big").status, 404);
  }

  // The same id ingests fine from another process, and the server running since before serves it
  // at once: it reads the store's link on every request.
  auto again = testing::run_command(ingest);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  auto info = http.get("/v1/images/big");
  ASSERT_EQ(info.status, 200) << info.body;
  EXPECT_EQ(json::parse(info.body)["width"], 6000);
  EXPECT_EQ(json::parse(http.get("/v1/images").body)["images"].size(), 1u);
  auto tile = http.get("/dzi/big_files/12/3_2.jpg");
  ASSERT_EQ(tile.status, 200);
  EXPECT_EQ(testing::decode_image(tile.body).width, 254 + 2);  // an inner tile: 254 px and 1 px overlap each side
  expect_store_clean(store, 1);
}

}  // namespace
}  // namespace zoomwarp
