// method=seam over the wire: `zoomwarp ingest` precomputes seam.default.bin and says how long it
// took; /viewport?method=seam is exactly w×h and fully covered at every zoom, on every image
// shape; with the image's own aspect it is the identity, so zoom 1 is the IIIF crop; /mesh
// answers 501; a damaged seam.default.bin is precomputed again (and logged); a significance edit
// writes the new version's file from the edited map.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string_view>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/analysis/method_files.h"
#include "warp/methods/seam/seam_carving.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HttpClient;

std::string version_dir(const std::string& store, const std::string& id) {
  return fs::canonical(store + "/images/" + id).string();
}

// The boats, 1280×800, with every channel in [32, 255]: a black screen pixel is one nothing drew.
tiles::Raster bright_boats() {
  tiles::Raster r = testing::resize(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"), 1280, 800);
  for (auto& v : r.pixels) v = std::uint8_t(32 + v * 223 / 255);
  return r;
}

int uncovered_pixels(const tiles::Raster& r) {
  int n = 0;
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x) {
      const std::uint8_t* p = r.row(y) + x * r.channels;
      n += p[0] == 0 && p[1] == 0 && p[2] == 0;
    }
  return n;
}

class Seam : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    const std::string file = dir_->path() + "/boats.png";
    testing::write_image(file, bright_boats());
    const auto ingest =
        testing::run_command({testing::zoomwarp_binary(), "ingest", file, "--store", store(), "--id", "boats",
                              "--analyses", "all"});
    ingest_output_ = new std::string(ingest.output);
    ASSERT_EQ(ingest.exit_code, 0) << ingest.output;
    // Eager analyses (--analyses all): these tests are about the stored maps (damaged, edited).
    server_ = new testing::ServerProcess(store(), {"--analyses", "all"});
  }
  static void TearDownTestSuite() {
    delete server_;
    delete ingest_output_;
    delete dir_;
  }
  static std::string store() { return dir_->path() + "/store"; }

  // Uploads `image` as PNG under `id`.
  void upload(const std::string& id, const tiles::Raster& image) {
    const std::string file = dir_->path() + "/" + id + ".png";
    testing::write_image(file, image);
    auto r = http.request("POST", "/v1/images?id=" + id, testing::read_file(file));
    ASSERT_EQ(r.status, 201) << r.body;
  }

  tiles::Raster viewport(const std::string& id, const std::string& query) {
    auto r = http.get("/v1/images/" + id + "/viewport?method=seam&format=png&" + query);
    EXPECT_EQ(r.status, 200) << query << ": " << r.body;
    return r.status == 200 ? testing::decode_image(r.body) : tiles::Raster();
  }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
  static std::string* ingest_output_;
};
testing::TempDir* Seam::dir_ = nullptr;
testing::ServerProcess* Seam::server_ = nullptr;
std::string* Seam::ingest_output_ = nullptr;

TEST_F(Seam, IngestPrecomputesTheVisibilityMapsAndSaysHowLong) {
  EXPECT_TRUE(fs::exists(version_dir(store(), "boats") + "/seam.default.bin"));
  EXPECT_NE(ingest_output_->find("seam.default.bin "), std::string::npos) << *ingest_output_;
  std::printf("[ figures ] %s", ingest_output_->c_str());
}

TEST_F(Seam, ViewportIsExactlyTheScreenAndCoveredAtEveryZoom) {
  for (auto [w, h] : {std::pair{360, 640}, {640, 360}, {400, 400}, {480, 300}})
    for (const char* zoom : {"0", "0.25", "0.5", "0.75", "1"})
      for (const char* centre : {"", "&cx=100&cy=700", "&cx=1200&cy=400"}) {
        const std::string q =
            "zoom=" + std::string(zoom) + "&w=" + std::to_string(w) + "&h=" + std::to_string(h) + centre;
        SCOPED_TRACE(q);
        const tiles::Raster r = viewport("boats", q);
        ASSERT_EQ(r.width, w);
        ASSERT_EQ(r.height, h);
        EXPECT_EQ(uncovered_pixels(r), 0);
      }
}

// 1280×800 on 480×300: nothing is carved, and zoom 1 around (640, 400) is the crop at (400, 250).
TEST_F(Seam, WithTheImagesAspectZoomOneIsTheIiifCrop) {
  const tiles::Raster shown = viewport("boats", "zoom=1&cx=640&cy=400&w=480&h=300");
  const tiles::Raster crop = testing::decode_image(http.get("/iiif/3/boats/400,250,480,300/max/0/default.png").body);
  const double db = testing::psnr(shown, crop);
  std::printf("[ figures ] seam viewport at zoom 1, equal aspect, vs IIIF crop: %.1f dB\n", db);
  EXPECT_GE(db, 40);
}

// A narrower screen carves columns: zoom 0 shows fewer image columns than the image has, and
// content from both ends of the image stays (carving, not cropping).
TEST_F(Seam, ANarrowScreenCarvesInsteadOfCropping) {
  const tiles::Raster carved = viewport("boats", "zoom=0&w=400&h=400");
  const tiles::Raster full = testing::decode_image(http.get("/iiif/3/boats/full/640,400/0/default.png").body);
  const tiles::Raster squeezed = testing::resize(full, 400, 400);
  const tiles::Raster cropped = testing::resize(testing::crop(full, {120, 0, 400, 400}), 400, 400);
  const double vs_squeezed = testing::psnr(carved, squeezed), vs_cropped = testing::psnr(carved, cropped);
  std::printf("[ figures ] seam at 1:1 vs uniform squeeze %.1f dB, vs centre crop %.1f dB\n", vs_squeezed, vs_cropped);
  // The left and right edges are the image's (seams rarely take border columns of a textured
  // photo); a centre crop would lose them.
  const tiles::Rect strip{0, 100, 8, 200};
  const tiles::Raster left = testing::crop(carved, strip);
  EXPECT_GT(testing::psnr(left, testing::crop(squeezed, strip)), testing::psnr(left, testing::crop(cropped, strip)));
}

// The view centre is carried through the carving: at zoom 1 the screen's centre pixel is the
// image pixel the request named, wherever seams removed columns left of it. 1280×800 on 400×400
// keeps 800 of 1280 image columns: with the maps at r image px per column (carved at a long side
// ≤ 512 px from the 640×400 analysis image: 512×320, r = 2.5), a kept map column p stands for
// image columns r·p … r·p + r, and screen pixel 200 samples carved x + 0.5 — the centre of image
// pixel r·p, for p whose r·p is whole. The stored map says which columns are kept, and so where p
// lands (centres whose view would be clamped at the carved image's edges are left out).
TEST_F(Seam, TheViewCentreIsTrackedThroughTheCarving) {
  const warp::RetargetingMethod& seam = *warp::find_retargeting_method("seam");
  const std::string file = version_dir(store(), "boats") + "/seam.default.bin";
  const warp::VisibilityMap map =
      warp::parse_visibility_maps(warp::method_payload("seam.default.bin", testing::read_file(file), seam)).horizontal;
  const double r = 1280.0 / map.length;
  const int k = map.length - int(std::lround(800 / r));
  const tiles::Raster source = bright_boats();
  int checked = 0;
  for (int cy : {250, 400, 520})
    for (int p = map.length / 4; p < map.length * 3 / 4 && checked < 4 * (cy / 250); p += 11) {
      const int line = int(cy / r);
      const auto kept = [&](int q) { return map.at(line, q) == 0 || map.at(line, q) > k; };
      if (!kept(p) || r * p != std::floor(r * p)) continue;  // carved away, or not at a whole image pixel
      int left = 0;  // kept columns left of p: its carved position is r · left
      for (int q = 0; q < p; ++q) left += kept(q);
      if (r * left < 200 || r * left > 600) continue;  // the view would be clamped at an edge
      const int cx = int(r * p);
      SCOPED_TRACE("cx " + std::to_string(cx) + " cy " + std::to_string(cy));
      const tiles::Raster shown =
          viewport("boats", "zoom=1&w=400&h=400&cx=" + std::to_string(cx) + "&cy=" + std::to_string(cy));
      ASSERT_EQ(shown.width, 400);
      for (int c = 0; c < 3; ++c) EXPECT_EQ(shown.row(200)[200 * 3 + c], source.row(cy)[cx * 3 + c]) << "channel " << c;
      ++checked;
    }
  EXPECT_GE(checked, 8);
}

// saliency=gbvs biases the seams with the GBVS map (seam.gbvs.bin, written at ingest): another
// carving of the same image, still exactly the screen.
TEST_F(Seam, GbvsSaliencyCarvesAnotherWay) {
  EXPECT_TRUE(fs::exists(version_dir(store(), "boats") + "/seam.gbvs.bin"));
  const tiles::Raster with_default = viewport("boats", "zoom=0&w=400&h=400");
  const tiles::Raster with_gbvs = viewport("boats", "zoom=0&w=400&h=400&saliency=gbvs");
  ASSERT_EQ(with_gbvs.width, 400);
  ASSERT_EQ(with_gbvs.height, 400);
  EXPECT_EQ(uncovered_pixels(with_gbvs), 0);
  EXPECT_NE(with_gbvs.pixels, with_default.pixels);
  std::printf("[ figures ] seam, 1:1 screen: gbvs vs default saliency %.1f dB\n", testing::psnr(with_gbvs, with_default));
}

TEST_F(Seam, MeshAnswers501WithAClearError) {
  auto r = http.get("/v1/images/boats/mesh?method=seam&zoom=0&w=400&h=400");
  EXPECT_EQ(r.status, 501);
  EXPECT_EQ(json::parse(r.body, nullptr, false),
            (json{{"error",
                   {{"code", "not_implemented"},
                    {"message", "method=seam carves pixels away and has no mesh; use /viewport?method=seam"}}}}));
}

TEST_F(Seam, EveryImageShapeGetsItsScreen) {
  struct Size {
    int w, h;
  };
  for (Size s : {Size{1, 1}, Size{16, 16}, Size{2, 10000}, Size{10000, 2}, Size{3000, 109}}) {
    const std::string id = "s" + std::to_string(s.w) + "x" + std::to_string(s.h);
    upload(id, testing::test_pattern(s.w, s.h, 3));
    for (Size screen : {Size{360, 640}, Size{640, 360}, Size{400, 400}})
      for (const char* zoom : {"0", "0.5", "1"}) {
        const std::string q =
            "zoom=" + std::string(zoom) + "&w=" + std::to_string(screen.w) + "&h=" + std::to_string(screen.h);
        SCOPED_TRACE(id + " " + q);
        const tiles::Raster r = viewport(id, q);
        EXPECT_EQ(r.width, screen.w);
        EXPECT_EQ(r.height, screen.h);
      }
  }
}

TEST_F(Seam, ADamagedFileIsPrecomputedAgainAndLogged) {
  upload("damaged", testing::resize(bright_boats(), 320, 200));
  const std::string file = version_dir(store(), "damaged") + "/seam.default.bin";
  std::string bytes = testing::read_file(file);
  ASSERT_GT(bytes.size(), 100u);
  for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 4; ++i) bytes[i] = char(~bytes[i]);
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  const tiles::Raster r = viewport("damaged", "zoom=0&w=200&h=200");
  EXPECT_EQ(r.width, 200);
  EXPECT_EQ(uncovered_pixels(r), 0);
  EXPECT_TRUE(server_->wait_for_log("method model file damaged, precomputed again in memory"));
  EXPECT_NE(server_->log().find("seam.default.bin"), std::string::npos);
}

// The visibility maps are biased by the significance map: an edit that marks a region important
// writes the new version's seam.default.bin from the edited map.
TEST_F(Seam, ASignificanceEditWritesTheNewVersionsFile) {
  upload("edited", testing::resize(bright_boats(), 320, 200));
  const std::string before = testing::read_file(version_dir(store(), "edited") + "/seam.default.bin");
  const json regions = {{"regions", {{{"rect", {0, 0, 160, 200}}, {"weight", 1}}}}};
  auto r = http.request("PATCH", "/v1/images/edited/significance", regions.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  const std::string after = testing::read_file(version_dir(store(), "edited") + "/seam.default.bin");
  EXPECT_NE(after, before);
  const tiles::Raster shown = viewport("edited", "zoom=0&w=200&h=200");
  EXPECT_EQ(shown.width, 200);
}

}  // namespace
}  // namespace zoomwarp
