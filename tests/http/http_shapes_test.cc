// Every image shape over the wire: tiny, square, very thin and very long images are uploaded to a
// real server, and /viewport and /mesh of every method /v1/methods lists (no fold-over), and
// /significance.png, answer for zoom 0, 0.5 and 1 on portrait, landscape and square screens — a
// 64×64 image used to kill the process. Zoom 1 on an image smaller than the screen is the 1:1
// crop, letterboxed.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;

struct Size {
  int w, h;
};

std::string id_of(Size s) { return "s" + std::to_string(s.w) + "x" + std::to_string(s.h); }

// Every triangle of a /mesh body counter-clockwise on the screen (none folded over).
void expect_no_fold_over(const json& mesh) {
  ASSERT_TRUE(mesh["vertices"].is_array() && mesh["triangles"].is_array());
  ASSERT_FALSE(mesh["triangles"].empty());
  for (const auto& t : mesh["triangles"]) {
    for (int k = 0; k < 3; ++k) ASSERT_LT(t[k].get<std::size_t>(), mesh["vertices"].size());
    const auto &a = mesh["vertices"][t[0].get<int>()], &b = mesh["vertices"][t[1].get<int>()],
               &c = mesh["vertices"][t[2].get<int>()];
    const double ax = a[2].get<double>(), ay = a[3].get<double>(), bx = b[2].get<double>(), by = b[3].get<double>(),
                 cx = c[2].get<double>(), cy = c[3].get<double>();
    const double area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
    // The JSON rounds screen positions to 0.001 px, which can flatten a sliver (a 2 px wide
    // image stretched to the screen's aspect): allow what that rounding can change.
    const double rounding = 0.002 * (std::hypot(bx - ax, by - ay) + std::hypot(cx - bx, cy - by) + std::hypot(ax - cx, ay - cy));
    ASSERT_GT(area2, -rounding) << "fold-over";
  }
}

class Shapes : public ::testing::TestWithParam<Size> {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    server_ = new testing::ServerProcess(dir_->path() + "/store");
  }
  static void TearDownTestSuite() {
    delete server_;
    delete dir_;
  }

  // Uploads a test pattern of the given size as PNG; returns its id.
  std::string upload(Size s) {
    const std::string file = dir_->path() + "/" + id_of(s) + ".png";
    testing::write_image(file, testing::test_pattern(s.w, s.h, 3));
    auto r = http.request("POST", "/v1/images?id=" + id_of(s), testing::read_file(file));
    EXPECT_EQ(r.status, 201) << r.body;
    return id_of(s);
  }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
};
testing::TempDir* Shapes::dir_ = nullptr;
testing::ServerProcess* Shapes::server_ = nullptr;

TEST_P(Shapes, ViewportMeshAndSignificanceAnswer) {
  const Size s = GetParam();
  const std::string base = "/v1/images/" + upload(s) + "/";
  auto sig = http.get(base + "significance.png");
  ASSERT_EQ(sig.status, 200) << sig.body;
  const tiles::Raster map = testing::decode_image(sig.body);
  EXPECT_GE(map.width, 1);
  EXPECT_GE(map.height, 1);
  const json methods = json::parse(http.get("/v1/methods").body)["methods"];
  ASSERT_GE(methods.size(), 3u);
  for (Size screen : {Size{360, 640}, Size{640, 360}, Size{400, 400}})
    for (const char* zoom : {"0", "0.5", "1"})
      for (const json& method : methods) {
        const std::string view = "zoom=" + std::string(zoom) + "&w=" + std::to_string(screen.w) +
                                 "&h=" + std::to_string(screen.h) + "&method=" + method["name"].get<std::string>();
        SCOPED_TRACE(view);
        auto r = http.get(base + "viewport?" + view + "&format=png");
        ASSERT_EQ(r.status, 200) << r.body;
        const tiles::Raster img = testing::decode_image(r.body);
        EXPECT_EQ(img.width, screen.w);
        EXPECT_EQ(img.height, screen.h);
        if (!method["mesh"]) continue;
        auto m = http.get(base + "mesh?" + view);
        ASSERT_EQ(m.status, 200) << m.body;
        expect_no_fold_over(json::parse(m.body));
      }
}

INSTANTIATE_TEST_SUITE_P(Sizes, Shapes,
                         ::testing::Values(Size{1, 1}, Size{2, 2}, Size{16, 16}, Size{64, 64}, Size{100, 100},
                                           Size{109, 3000}, Size{3000, 109}, Size{2, 10000}, Size{10000, 2}),
                         [](const auto& info) { return id_of(info.param); });

// A 1024×512 panorama on a 360×640 screen at zoom 1: the 1:1 crop around the centre, with black
// bands of 64 px above and below — not magnified ×1.25 to fill the screen.
TEST_F(Shapes, ZoomOneOnAnImageSmallerThanTheScreenIsLetterboxedOneToOne) {
  const Size s{1024, 512};
  const std::string id = upload(s);
  auto r = http.get("/v1/images/" + id + "/viewport?zoom=1&cx=512&cy=256&w=360&h=640&format=png");
  ASSERT_EQ(r.status, 200) << r.body;
  const tiles::Raster shown = testing::decode_image(r.body);
  ASSERT_EQ(shown.width, 360);
  ASSERT_EQ(shown.height, 640);
  const tiles::Raster source = testing::test_pattern(s.w, s.h, 3);
  tiles::Raster want(360, 640, 3);
  for (int y = 64; y < 576; ++y) std::copy_n(source.row(y - 64) + 3 * 332, 3 * 360, want.row(y));
  EXPECT_EQ(testing::psnr(testing::take_channels(shown, 3), want), std::numeric_limits<double>::infinity());
}

}  // namespace
}  // namespace zoomwarp
