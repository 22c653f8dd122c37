// Uploads in the formats digital libraries keep (issue 31) through a real server: a lossless
// JPEG 2000 master and an AVIF, made with Debian's own encoders (opj_compress, heif-enc) from a
// crop of a bundled photograph, are published (201) and served by IIIF as the picture they hold;
// an AVIF whose header declares more pixels than the server takes is refused (413) as a JPEG
// would be.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <string>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;
using testing::ServerProcess;
using testing::TempDir;

constexpr int kWidth = 512, kHeight = 384;

void run(const std::string& dir, const std::string& command) {
  ASSERT_EQ(std::system(("cd '" + dir + "' && " + command + " > tool.log 2>&1").c_str()), 0) << command;
}

TEST(SourceFormatUploads, Jpeg2000AndAvifArePublishedAndServed) {
  TempDir dir;
  const tiles::Raster picture = testing::crop(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"),
                                              {1000, 500, kWidth, kHeight});
  testing::write_image(dir.path() + "/source.tif", picture);
  testing::write_image(dir.path() + "/source.png", picture);
  run(dir.path(), "opj_compress -i source.tif -o master.jp2");
  run(dir.path(), "heif-enc -A -q 90 source.png -o photo.avif");
  run(dir.path(), "heif-convert photo.avif avif-decoded.png");

  ServerProcess server(dir.path() + "/store", {"--open-writes"});
  HttpClient http(server.port());
  for (const auto& [id, file, exact] : {std::tuple{"master", "master.jp2", true}, {"photo", "photo.avif", false}}) {
    const auto posted = http.request("POST", std::string("/v1/images?id=") + id, testing::read_file(dir.path() + "/" + file));
    ASSERT_EQ(posted.status, 201) << file << ": " << posted.body;
    const json image = json::parse(http.get(std::string("/v1/images/") + id).body);
    EXPECT_EQ(image["width"], kWidth) << file;
    EXPECT_EQ(image["height"], kHeight) << file;
    const auto full = http.get(std::string("/iiif/3/") + id + "/full/max/0/default.png");
    ASSERT_EQ(full.status, 200) << file;
    const tiles::Raster served = testing::decode_image(full.body);
    const double db = testing::psnr(served, exact ? picture : testing::load_image(dir.path() + "/avif-decoded.png"));
    std::cout << "[ figures ] " << file << " served by IIIF: " << db << " dB from the decoded source\n";
    if (exact) {
      EXPECT_EQ(db, std::numeric_limits<double>::infinity()) << file;
    } else {
      EXPECT_GE(db, 40.0) << file;
    }
  }

  // The same AVIF with its image extents ('ispe') patched to 4000 × 4000: over --max-pixels.
  ServerProcess strict(dir.path() + "/strict", {"--open-writes", "--max-pixels", "5000000"});
  std::string avif = testing::read_file(dir.path() + "/photo.avif");
  std::size_t patched = 0;
  for (std::size_t at = avif.find("ispe"); at != std::string::npos; at = avif.find("ispe", at + 4), ++patched)
    avif.replace(at + 8, 8, std::string("\0\0\x0F\xA0\0\0\x0F\xA0", 8));
  ASSERT_GT(patched, 0u);
  const auto refused = HttpClient(strict.port()).request("POST", "/v1/images?id=huge", avif);
  EXPECT_EQ(refused.status, 413) << refused.body;
  EXPECT_EQ(json::parse(refused.body)["error"]["code"], "image_too_large");
}

// AVIF and JPEG XL answers (tiles/encode.h): a view in each is the PNG view's picture, tagged with
// its type, decoded by libheif and libjxl's decoder; so are an IIIF image and a DZI tile.
TEST(SourceFormatUploads, ViewsAndTilesAreAnsweredInAvifAndJpegXl) {
  TempDir dir;
  ServerProcess server(dir.path() + "/store", {"--open-writes"});
  HttpClient http(server.port());
  ASSERT_EQ(http.request("POST", "/v1/images?id=boats", testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg")).status, 201);
  const std::string view = "/v1/images/boats/viewport?zoom=0.3&w=480&h=360&method=traditional&format=";
  const auto png = http.get(view + "png");
  for (const std::string format : {"avif", "jxl"}) {
    SCOPED_TRACE(format);
    const std::string type = "image/" + format;
    const auto answer = http.get(view + format);
    ASSERT_EQ(answer.status, 200) << answer.body;
    EXPECT_EQ(answer.header("content-type"), type);
    const double db = testing::psnr(testing::decode_image(answer.body), testing::decode_image(png.body));
    std::cout << "[ figures ] a 480x360 view: " << format << " " << answer.body.size() << " bytes, " << db << " dB from the PNG view\n";
    EXPECT_GE(db, 32.0) << "as close as the default JPEG answer (33.2 dB on encode_bench's view)";
    for (const std::string path : {"/iiif/3/boats/full/320,/0/default.", "/dzi/boats_files/9/0_0."}) {
      const auto r = http.get(path + format);
      ASSERT_EQ(r.status, 200) << path << ": " << r.body;
      EXPECT_EQ(r.header("content-type"), type) << path;
      const tiles::Raster reference = testing::decode_image(http.get(path + "png").body);
      EXPECT_GE(testing::psnr(testing::decode_image(r.body), reference), 30.0) << path << " (the same size and picture)";
    }
  }
  EXPECT_EQ(http.get(view + "heic").status, 400);
}

}  // namespace
}  // namespace zoomwarp
