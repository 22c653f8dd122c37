// Deep Zoom and IIIF responses checked against references computed independently with
// OpenImageIO: sizes exactly, pixels within tolerance — exactly for lossless answers. The sample
// JPEG is stored as JPEG tiles (issue 18), so its reference is its stored full-resolution level
// read straight from the store's file (itself checked against the source file); the PNG's is the
// source file.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <regex>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;
using tiles::Raster;

// One server with the sample (RGB JPEG) and the panorama (RGBA PNG) for the whole suite.
class Tiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    server_ = new testing::ServerProcess(dir_->path() + "/store", {"--iiif-max-width", "3000", "--iiif-max-height",
                                                                     "2000", "--iiif-max-area", "5000000"});
    HttpClient http(server_->port());
    for (auto [id, file] : {std::pair{"boats", "boats_lake_sunset.jpg"}, {"pano", "pano_grossmugl_field_4to1.png"}}) {
      auto r = http.request("POST", std::string("/v1/images?id=") + id, testing::read_file(testing::samples_dir() + "/" + file));
      ASSERT_EQ(r.status, 201) << r.body;
    }
    boats_ = new Raster(testing::load_image(dir_->path() + "/store/images/boats/level_0.tif"));
    ASSERT_GE(testing::psnr(*boats_, testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg")), 40.0);
    pano_ = new Raster(testing::load_image(testing::samples_dir() + "/pano_grossmugl_field_4to1.png"));
  }
  static void TearDownTestSuite() {
    delete boats_;
    delete pano_;
    delete server_;
    delete dir_;
  }

  HttpClient http{server_->port()};
  Raster get_image(const std::string& target) {
    auto r = http.get(target);
    EXPECT_EQ(r.status, 200) << target << " " << r.body;
    return testing::decode_image(r.body);
  }

  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
  static Raster *boats_, *pano_;
};
testing::TempDir* Tiles::dir_ = nullptr;
testing::ServerProcess* Tiles::server_ = nullptr;
Raster* Tiles::boats_ = nullptr;
Raster* Tiles::pano_ = nullptr;

TEST_F(Tiles, DziDescriptor) {
  auto r = http.get("/dzi/boats.dzi");
  ASSERT_EQ(r.status, 200);
  EXPECT_NE(r.header("content-type").find("xml"), std::string::npos);
  EXPECT_NE(r.body.find(R"(xmlns="http://schemas.microsoft.com/deepzoom/2008")"), std::string::npos);
  EXPECT_NE(r.body.find(R"(Format="jpg" Overlap="1" TileSize="254")"), std::string::npos);
  EXPECT_NE(r.body.find(R"(<Size Width="2560" Height="1600"/>)"), std::string::npos);
  EXPECT_NE(http.get("/dzi/pano.dzi").body.find(R"(Format="png")"), std::string::npos) << "alpha images advertise png";
}

TEST_F(Tiles, DziFullResolutionTilesAreCropsOfTheSource) {
  // Level 12 is full resolution. Tile (3, 2) covers x 761..1017, y 507..763 (254 + overlap 1 each side).
  Raster png = get_image("/dzi/boats_files/12/3_2.png");
  ASSERT_EQ(png.width, 256);
  ASSERT_EQ(png.height, 256);
  EXPECT_EQ(testing::psnr(png, testing::crop(*boats_, {761, 507, 256, 256})), std::numeric_limits<double>::infinity());
  Raster jpg = get_image("/dzi/boats_files/12/3_2.jpg");
  EXPECT_GT(testing::psnr(jpg, testing::crop(*boats_, {761, 507, 256, 256})), 32.0);
  Raster webp = get_image("/dzi/boats_files/12/3_2.webp");
  EXPECT_GT(testing::psnr(webp, testing::crop(*boats_, {761, 507, 256, 256})), 30.0);
  // Edge tiles: the first has no left/top overlap; the last column is 2560 - 10*254 = 20 px + 1 overlap.
  Raster first = get_image("/dzi/boats_files/12/0_0.png");
  EXPECT_EQ(first.width, 255);
  EXPECT_EQ(first.height, 255);
  Raster corner = get_image("/dzi/boats_files/12/10_6.png");
  EXPECT_EQ(corner.width, 21);
  EXPECT_EQ(corner.height, 77);
  EXPECT_EQ(testing::psnr(corner, testing::crop(*boats_, {2539, 1523, 21, 77})), std::numeric_limits<double>::infinity());
}

TEST_F(Tiles, DziLowerLevelsMatchADownscaledSource) {
  // Level 9 is 320×200: one tile holding the whole image.
  Raster tile = get_image("/dzi/boats_files/9/0_0.png");
  ASSERT_EQ(tile.width, 255);
  ASSERT_EQ(tile.height, 200);
  Raster reference = testing::crop(testing::resize(*boats_, 320, 200), {0, 0, 255, 200});
  EXPECT_GT(testing::psnr(tile, reference), 28.0);
  // Level 0 is 1×1, level 1 is 2×1.
  EXPECT_EQ(get_image("/dzi/boats_files/0/0_0.png").width, 1);
  Raster l1 = get_image("/dzi/boats_files/1/0_0.png");
  EXPECT_EQ(l1.width, 2);
  EXPECT_EQ(l1.height, 1);
}

TEST_F(Tiles, DziAlphaIsKept) {
  Raster tile = get_image("/dzi/pano_files/11/2_0.png");  // full resolution, 2048×512
  ASSERT_EQ(tile.channels, 4);
  EXPECT_EQ(testing::psnr(tile, testing::crop(*pano_, {507, 0, 256, 255})), std::numeric_limits<double>::infinity());
  Raster jpg = get_image("/dzi/pano_files/11/2_0.jpg");
  EXPECT_EQ(jpg.channels, 3) << "JPEG is flattened";
}

TEST_F(Tiles, DziBadTileRequests) {
  EXPECT_EQ(http.get("/dzi/boats_files/13/0_0.jpg").status, 404);
  EXPECT_EQ(http.get("/dzi/boats_files/12/11_0.jpg").status, 404);
  EXPECT_EQ(http.get("/dzi/boats_files/12/0_7.jpg").status, 404);
  EXPECT_EQ(http.get("/dzi/boats_files/0/1_0.jpg").status, 404);
  for (const char* bad : {"/dzi/boats_files/-1/0_0.jpg", "/dzi/boats_files/x/0_0.jpg", "/dzi/boats_files/12/0-0.jpg",
                          "/dzi/boats_files/12/0_0", "/dzi/boats_files/12/0_0.gif", "/dzi/boats_files/99999999999/0_0.jpg",
                          "/dzi/boats_files/12/1e3_0.jpg", "/dzi/boats_files/12/0_nan.jpg", "/dzi/boats_files/12/_0.jpg"}) {
    auto r = http.get(bad);
    EXPECT_EQ(r.status, 400) << bad;
    EXPECT_NE(r.body.find("\"error\""), std::string::npos) << bad;
  }
  EXPECT_EQ(http.get("/dzi/nope_files/12/0_0.jpg").status, 404);
}

TEST_F(Tiles, IiifInfoJson) {
  auto r = http.get("/iiif/3/boats/info.json");
  ASSERT_EQ(r.status, 200);
  auto j = json::parse(r.body);
  EXPECT_EQ(j["@context"], "http://iiif.io/api/image/3/context.json");
  EXPECT_EQ(j["id"], "http://127.0.0.1:" + std::to_string(server_->port()) + "/iiif/3/boats");
  EXPECT_EQ(j["type"], "ImageService3");
  EXPECT_EQ(j["protocol"], "http://iiif.io/api/image");
  EXPECT_EQ(j["profile"], "level2");
  EXPECT_EQ(j["width"], 2560);
  EXPECT_EQ(j["height"], 1600);
  EXPECT_EQ(j["maxWidth"], 3000);
  EXPECT_EQ(j["maxHeight"], 2000);
  EXPECT_EQ(j["maxArea"], 5000000);
  ASSERT_EQ(j["tiles"].size(), 1u);
  EXPECT_EQ(j["tiles"][0]["width"], 256);
  EXPECT_EQ(j["tiles"][0]["scaleFactors"], json({1, 2, 4, 8, 16}));
  ASSERT_FALSE(j["sizes"].empty());
  for (const auto& s : j["sizes"]) {
    EXPECT_LE(s["width"].get<int>(), 3000);
    EXPECT_LE(s["width"].get<long long>() * s["height"].get<long long>(), 5000000);
  }
  EXPECT_EQ(j["sizes"].back(), json({{"width", 2560}, {"height", 1600}}));
  EXPECT_EQ(j["extraFormats"], json({"webp", "avif", "jxl"}));
  // JSON-LD when asked for, and the base URI redirects to info.json.
  auto ld = http.get("/iiif/3/boats/info.json", {{"Accept", "application/ld+json"}});
  EXPECT_NE(ld.header("content-type").find("application/ld+json"), std::string::npos);
  auto base = http.get("/iiif/3/boats");
  EXPECT_EQ(base.status, 303);
  EXPECT_EQ(base.header("location"), "/iiif/3/boats/info.json");
}

// Test-side orientation, written out independently of the server's implementation.
Raster rotate_cw(const Raster& in, int degrees) {
  if (degrees == 0) return in;
  const bool swap = degrees != 180;
  Raster out(swap ? in.height : in.width, swap ? in.width : in.height, in.channels);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      int sx, sy;
      if (degrees == 90) sx = y, sy = in.height - 1 - x;
      else if (degrees == 180) sx = in.width - 1 - x, sy = in.height - 1 - y;
      else sx = in.width - 1 - y, sy = x;
      std::copy_n(in.row(sy) + sx * in.channels, in.channels, out.row(y) + x * in.channels);
    }
  return out;
}
Raster mirror(const Raster& in) {
  Raster out(in.width, in.height, in.channels);
  for (int y = 0; y < in.height; ++y)
    for (int x = 0; x < in.width; ++x)
      std::copy_n(in.row(y) + (in.width - 1 - x) * in.channels, in.channels, out.row(y) + x * in.channels);
  return out;
}

TEST_F(Tiles, IiifImageRequestsTable) {
  struct Row {
    const char* path;      // region/size/rotation/quality.format
    tiles::Rect region;    // expected region of the source
    int w, h;              // expected output size before rotation
    int rotation;
    bool mirrored;
    double min_psnr;
  };
  const Row rows[] = {
      {"0,0,256,256/max/0/default.png", {0, 0, 256, 256}, 256, 256, 0, false, 1e9},
      {"512,512,512,512/256,/0/default.png", {512, 512, 512, 512}, 256, 256, 0, false, 28},  // an IIIF tile at scale 2
      {"2304,1536,512,512/128,/0/default.jpg", {2304, 1536, 256, 64}, 128, 32, 0, false, 28},  // clipped edge tile
      {"full/!640,640/0/default.png", {0, 0, 2560, 1600}, 640, 400, 0, false, 28},
      {"full/400,/0/default.jpg", {0, 0, 2560, 1600}, 400, 250, 0, false, 27},
      {"full/,100/0/default.webp", {0, 0, 2560, 1600}, 160, 100, 0, false, 26},
      {"full/,100/0/default.avif", {0, 0, 2560, 1600}, 160, 100, 0, false, 26},
      {"512,512,512,512/256,/0/default.avif", {512, 512, 512, 512}, 256, 256, 0, false, 28},
      {"512,512,512,512/256,/0/default.jxl", {512, 512, 512, 512}, 256, 256, 0, false, 28},
      {"full/pct:10/0/default.png", {0, 0, 2560, 1600}, 256, 160, 0, false, 28},
      {"square/300,300/0/default.png", {480, 0, 1600, 1600}, 300, 300, 0, false, 28},
      {"pct:25,25,50,50/640,400/0/default.png", {640, 400, 1280, 800}, 640, 400, 0, false, 28},
      {"100,200,300,100/max/90/default.png", {100, 200, 300, 100}, 300, 100, 90, false, 1e9},
      {"100,200,300,100/max/180/default.png", {100, 200, 300, 100}, 300, 100, 180, false, 1e9},
      {"100,200,300,100/max/270/default.png", {100, 200, 300, 100}, 300, 100, 270, false, 1e9},
      {"100,200,300,100/max/!0/default.png", {100, 200, 300, 100}, 300, 100, 0, true, 1e9},
      {"100,200,300,100/max/!90/default.png", {100, 200, 300, 100}, 300, 100, 90, true, 1e9},
      {"10,10,50,40/^200,/0/default.png", {10, 10, 50, 40}, 200, 160, 0, false, 22},  // upscaled
      {"full/max/0/default.jpg", {0, 0, 2560, 1600}, 2560, 1600, 0, false, 33},
  };
  for (const Row& row : rows) {
    SCOPED_TRACE(row.path);
    Raster got = get_image(std::string("/iiif/3/boats/") + row.path);
    Raster expected = testing::crop(*boats_, row.region);
    if (expected.width != row.w || expected.height != row.h) expected = testing::resize(expected, row.w, row.h);
    if (row.mirrored) expected = mirror(expected);
    expected = rotate_cw(expected, row.rotation);
    ASSERT_EQ(got.width, expected.width);
    ASSERT_EQ(got.height, expected.height);
    EXPECT_GE(testing::psnr(got, expected), row.min_psnr);
  }
}

TEST_F(Tiles, IiifQualities) {
  Raster grey = get_image("/iiif/3/boats/0,0,200,100/max/0/gray.png");
  ASSERT_EQ(grey.channels, 1);
  Raster colour = testing::crop(*boats_, {0, 0, 200, 100});
  Raster luma(200, 100, 1);
  for (std::size_t i = 0; i < luma.pixels.size(); ++i)
    luma.pixels[i] = std::uint8_t(std::lround(0.2126 * colour.pixels[3 * i] + 0.7152 * colour.pixels[3 * i + 1] +
                                              0.0722 * colour.pixels[3 * i + 2]));
  EXPECT_GT(testing::psnr(grey, luma), 45.0);
  Raster bitonal = get_image("/iiif/3/boats/0,0,200,100/max/0/bitonal.png");
  ASSERT_EQ(bitonal.channels, 1);
  int blacks = 0;
  for (auto v : bitonal.pixels) {
    ASSERT_TRUE(v == 0 || v == 255);
    blacks += v == 0;
  }
  EXPECT_GT(blacks, 0);
  EXPECT_EQ(get_image("/iiif/3/boats/0,0,200,100/max/0/color.png").channels, 3);
  EXPECT_EQ(get_image("/iiif/3/pano/0,0,200,100/max/0/default.png").channels, 4);
  EXPECT_EQ(get_image("/iiif/3/pano/0,0,200,100/max/0/gray.png").channels, 2);
}

TEST_F(Tiles, IiifErrorsOverHttp) {
  auto status = [&](const std::string& p) { return http.get("/iiif/3/boats/" + p).status; };
  EXPECT_EQ(status("full/max/0/default.gif"), 501);
  EXPECT_EQ(status("full/max/45/default.jpg"), 501);
  EXPECT_EQ(status("full/max/0/sepia.jpg"), 400);
  EXPECT_EQ(status("full/4000,/0/default.jpg"), 400);   // upscaling without ^
  EXPECT_EQ(status("full/^3001,/0/default.jpg"), 400);  // over maxWidth
  EXPECT_EQ(status("pct:nan,0,10,10/max/0/default.jpg"), 400);
  EXPECT_EQ(status("0,0,inf,10/max/0/default.jpg"), 400);
  EXPECT_EQ(status("9999,0,10,10/max/0/default.jpg"), 400);
  EXPECT_EQ(status("full/max/0"), 400);
  EXPECT_EQ(http.get("/iiif/3/nope/full/max/0/default.jpg").status, 404);
  EXPECT_EQ(http.get("/iiif/2/boats/info.json").status, 404);
}

}  // namespace
}  // namespace zoomwarp
