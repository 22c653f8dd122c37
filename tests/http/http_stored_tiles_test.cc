// Stored JPEG tiles sent as they are (api/README.md, "Stored tiles sent as they are"): the answer
// to a request that is exactly one stored tile is the level's JPEGTables and the tile's bytes,
// read here independently with libtiff; every other request is decoded and encoded as before.
// The sample JPEG (2560 × 1600) is stored with JPEG tiles, the PNG panorama losslessly.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/metrics_scrape.h"
#include "tests/support/server_process.h"
#include "tests/support/stored_tile_reference.h"

namespace zoomwarp {
namespace {

using testing::HttpClient;
using testing::HttpResponse;
using tiles::Raster;

constexpr const char* kPassedThrough = "zoomwarp_tiles_passthrough_total";

class StoredTiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    server_ = new testing::ServerProcess(dir_->path() + "/store",
                                         {"--response-cache", "0", "--dzi-tile-size", "256", "--dzi-overlap", "0"});
    HttpClient http(server_->port());
    for (auto [id, file] : {std::pair{"boats", "boats_lake_sunset.jpg"}, {"broken", "boats_lake_sunset.jpg"},
                            {"pano", "pano_grossmugl_field_4to1.png"}}) {
      auto r = http.request("POST", std::string("/v1/images?id=") + id,
                            testing::read_file(testing::samples_dir() + "/" + file));
      ASSERT_EQ(r.status, 201) << r.body;
    }
  }
  static void TearDownTestSuite() {
    delete server_;
    delete dir_;
  }

  static std::string level(const std::string& id, int k) {
    return dir_->path() + "/store/images/" + id + "/level_" + std::to_string(k) + ".tif";
  }
  double passed_through() const { return testing::metric(server_->port(), kPassedThrough); }
  HttpResponse get_ok(const std::string& target) {
    HttpResponse r = http.get(target);
    EXPECT_EQ(r.status, 200) << target << " " << r.body;
    return r;
  }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
};
testing::TempDir* StoredTiles::dir_ = nullptr;
testing::ServerProcess* StoredTiles::server_ = nullptr;

TEST_F(StoredTiles, AnIiifTileIsTheStoredTileWithTheUsualHeaders) {
  const double before = passed_through();
  const HttpResponse r = get_ok("/iiif/3/boats/768,512,256,256/256,/0/default.jpg");
  EXPECT_TRUE(r.body == testing::stored_tile_jpeg(level("boats", 0), 3, 2));
  EXPECT_EQ(r.header("content-type"), "image/jpeg");
  EXPECT_EQ(r.header("cache-control"), "public, max-age=60");
  EXPECT_NE(r.header("link").find("level2"), std::string::npos);
  ASSERT_FALSE(r.header("etag").empty());
  EXPECT_EQ(http.get("/iiif/3/boats/768,512,256,256/256,/0/default.jpg", {{"If-None-Match", r.header("etag")}}).status, 304);
  // Any size syntax resolving to the tile's size, and quality color: the same tile.
  EXPECT_TRUE(get_ok("/iiif/3/boats/768,512,256,256/max/0/color.jpg").body == r.body);
  EXPECT_EQ(passed_through(), before + 2);
}

TEST_F(StoredTiles, ACoarseLevelsTileIsItsStoredTile) {
  // Level 2 is 640 × 400; its tile (1, 0) is full-resolution 1024,0 to 2048,1024.
  EXPECT_TRUE(get_ok("/iiif/3/boats/1024,0,1024,1024/256,256/0/default.jpg").body ==
              testing::stored_tile_jpeg(level("boats", 2), 1, 0));
}

// Level 3 is 320 × 200: tile (1, 0) is 64 × 200 of a stored (padded) 256 × 256; level 0's last
// row is 64 high. The answer has the edge tile's size and the stored pixels.
TEST_F(StoredTiles, AnEdgeTileHasItsSizeAndTheStoredPixels) {
  struct Case {
    const char* target;
    int level, tx, ty, w, h;
  };
  const double before = passed_through();
  for (const Case c : {Case{"/iiif/3/boats/2048,0,512,1600/64,200/0/default.jpg", 3, 1, 0, 64, 200},
                       Case{"/iiif/3/boats/1536,1536,256,64/256,64/0/default.jpg", 0, 6, 6, 256, 64}}) {
    SCOPED_TRACE(c.target);
    const Raster got = testing::decode_jpeg_blockwise(get_ok(c.target).body);
    ASSERT_EQ(got.width, c.w);
    ASSERT_EQ(got.height, c.h);
    const Raster stored = testing::decode_jpeg_blockwise(testing::stored_tile_jpeg(level("boats", c.level), c.tx, c.ty));
    EXPECT_TRUE(got.pixels == testing::crop(stored, {0, 0, c.w, c.h}).pixels);
  }
  EXPECT_EQ(passed_through(), before + 2);
}

TEST_F(StoredTiles, OtherRequestsAreDecodedAndEncodedAsBefore) {
  const std::string stored = testing::stored_tile_jpeg(level("boats", 0), 3, 2);
  const Raster stored_pixels = testing::decode_image(stored);
  const double before = passed_through();
  for (const char* target : {"/iiif/3/boats/768,512,256,256/256,/90/default.jpg",
                             "/iiif/3/boats/768,512,256,256/256,/!0/default.jpg",
                             "/iiif/3/boats/768,512,256,256/256,/0/gray.jpg",
                             "/iiif/3/boats/768,512,256,256/256,/0/default.png",
                             "/iiif/3/boats/770,512,256,256/256,/0/default.jpg",
                             "/iiif/3/boats/768,512,256,256/255,/0/default.jpg",
                             "/dzi/boats_files/12/3_2.png"}) {
    SCOPED_TRACE(target);
    const HttpResponse r = get_ok(target);
    EXPECT_FALSE(r.body == stored);
    const Raster got = testing::decode_image(r.body);
    EXPECT_GT(got.width, 200);
  }
  // The rotated tile is the stored pixels turned, encoded again (not the stored bytes).
  const Raster rotated = testing::decode_image(get_ok("/iiif/3/boats/768,512,256,256/256,/180/default.jpg").body);
  Raster turned(256, 256, 3);
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x)
      for (int c = 0; c < 3; ++c)
        turned.pixels[(std::size_t(y) * 256 + x) * 3 + c] = stored_pixels.pixels[(std::size_t(255 - y) * 256 + 255 - x) * 3 + c];
  EXPECT_GT(testing::psnr(rotated, turned), 30.0);
  EXPECT_EQ(passed_through(), before) << "none of these is a stored tile as it is";
}

TEST_F(StoredTiles, ALosslesslyStoredImageIsNeverPassedThrough) {
  const double before = passed_through();
  get_ok("/iiif/3/pano/0,0,256,256/256,/0/default.jpg");
  get_ok("/dzi/pano_files/11/0_0.jpg");
  EXPECT_EQ(passed_through(), before);
}

TEST_F(StoredTiles, DeepZoomWithTheStoredGridSendsStoredTiles) {
  EXPECT_NE(get_ok("/dzi/boats.dzi").body.find(R"(Overlap="0" TileSize="256")"), std::string::npos);
  const double before = passed_through();
  EXPECT_TRUE(get_ok("/dzi/boats_files/12/3_2.jpg").body == testing::stored_tile_jpeg(level("boats", 0), 3, 2));
  EXPECT_TRUE(get_ok("/dzi/boats_files/10/1_0.jpg").body == testing::stored_tile_jpeg(level("boats", 2), 1, 0));
  EXPECT_EQ(passed_through(), before + 2);
}

// The answer a damaged pyramid gives today, whichever path reads it.
TEST_F(StoredTiles, ADamagedLevelFileIsA500) {
  std::ofstream(level("broken", 1), std::ios::binary | std::ios::trunc) << "JUNK";
  for (const char* target : {"/iiif/3/broken/0,0,512,512/256,/0/default.jpg", "/iiif/3/broken/0,0,512,512/256,/0/default.png"}) {
    SCOPED_TRACE(target);
    const HttpResponse r = http.get(target);
    EXPECT_EQ(r.status, 500);
    EXPECT_EQ(nlohmann::json::parse(r.body, nullptr, false)["error"]["code"], "internal_error") << r.body;
  }
}

}  // namespace
}  // namespace zoomwarp
