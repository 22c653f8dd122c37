// method=retarget-zoom through the server: the registered Retargeting+Zooming method renders
// exactly w × h at every zoom, is the IIIF crop at zoom 1 on a screen of the image's aspect, and
// its /mesh at zoom 0 lists the whole fine uniform mesh.
#include <gtest/gtest.h>

#include <limits>
#include <nlohmann/json.hpp>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;

class RetargetZoomHttp : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    server_ = new testing::ServerProcess(dir_->path() + "/store");
    HttpClient http(server_->port());
    auto r = http.request("POST", "/v1/images?id=boats", testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg"));
    ASSERT_EQ(r.status, 201) << r.body;
  }
  static void TearDownTestSuite() {
    delete server_;
    delete dir_;
  }

  tiles::Raster image(const std::string& target) {
    auto r = http.get(target);
    EXPECT_EQ(r.status, 200) << target << ": " << r.body;
    return testing::decode_image(r.body);
  }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
};
testing::TempDir* RetargetZoomHttp::dir_ = nullptr;
testing::ServerProcess* RetargetZoomHttp::server_ = nullptr;

TEST_F(RetargetZoomHttp, ViewportIsExactlyTheScreenAtEveryZoomAndTheCropAtZoomOne) {
  for (const char* zoom : {"0", "0.3", "0.7", "1"}) {
    const tiles::Raster v = image(std::string("/v1/images/boats/viewport?method=retarget-zoom&w=360&h=640&format=png&zoom=") + zoom);
    EXPECT_EQ(v.width, 360) << zoom;
    EXPECT_EQ(v.height, 640) << zoom;
  }
  // 480 × 300 is the image's 16:10: the warp is the identity, zoom 1 the plain crop around (900, 500).
  const tiles::Raster crop = image("/v1/images/boats/viewport?method=retarget-zoom&zoom=1&cx=900&cy=500&w=480&h=300&format=png");
  const tiles::Raster iiif = image("/iiif/3/boats/660,350,480,300/max/0/default.png");
  EXPECT_EQ(testing::psnr(crop, iiif), std::numeric_limits<double>::infinity());
}

TEST_F(RetargetZoomHttp, MeshAtZoomZeroListsTheWholeFineMesh) {
  auto r = http.get("/v1/images/boats/mesh?method=retarget-zoom&zoom=0&w=360&h=640");
  ASSERT_EQ(r.status, 200) << r.body;
  const json fine = json::parse(r.body);
  r = http.get("/v1/images/boats/mesh?method=icaz&zoom=0&w=360&h=640");
  ASSERT_EQ(r.status, 200) << r.body;
  const json adaptive = json::parse(r.body);
  std::printf("[ figures ] boats /mesh at z = 0, 360×640: retarget-zoom %zu triangles, icaz %zu\n", fine["triangles"].size(),
              adaptive["triangles"].size());
  // 4.1 MP at 500 px² (Delaunay refinement makes them smaller still): more than 8 000 triangles.
  EXPECT_GT(fine["triangles"].size(), 4096000u / 500);
  EXPECT_GT(fine["triangles"].size(), 5 * adaptive["triangles"].size());
}

}  // namespace
}  // namespace zoomwarp
