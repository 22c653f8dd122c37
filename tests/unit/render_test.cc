// render_view on hand-made views, where the expected pixels follow from the mapping alone.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "tiles/pyramid_reader.h"
#include "warp/render/render.h"

namespace zoomwarp {
namespace {

// A wide strip whose red channel is a smooth ramp along x: the value says where a pixel came from.
constexpr int kWidth = 40000, kHeight = 32;
double ramp(double x) { return 255.0 * x / kWidth; }

tiles::Raster ramp_strip() {
  tiles::Raster r(kWidth, kHeight, 3);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      std::uint8_t* p = r.row(y) + 3 * x;
      p[0] = std::uint8_t(std::lround(ramp(x + 0.5))), p[1] = 128, p[2] = 64;
    }
  return r;
}

// Source rectangle [u0, u0 + w] × [0, kHeight] shown 1:1 at screen x = sx (two triangles).
void add_quad(warp::View& v, double u0, double w, double sx) {
  const int base = int(v.source.vertices.size());
  for (const auto& [du, dv] : {std::pair{0.0, 0.0}, {w, 0.0}, {w, double(kHeight)}, {0.0, double(kHeight)}}) {
    v.source.vertices.push_back({u0 + du, dv});
    v.screen.push_back({sx + du, dv});
  }
  for (const warp::Triangle& t : {warp::Triangle{base, base + 1, base + 2}, warp::Triangle{base, base + 2, base + 3}}) {
    v.visible.push_back(int(v.source.triangles.size()));
    v.source.triangles.push_back(t);
  }
}

// Two pieces of the strip ~39 600 px apart drawn side by side at magnification 1: both are read
// from level 0, and one patch spanning both would be wider than cv::remap's fixed-point positions
// reach (32 767 px). The far piece must still show its own pixels, not those of x ≈ 32 767.
TEST(RenderView, FarApartTrianglesOfOneLevelShowTheirOwnPixels) {
  testing::TempDir dir;
  const std::string file = dir.path() + "/strip.png";
  testing::write_image(file, ramp_strip());
  tiles::Store store(dir.path() + "/store");
  tiles::ingest_image(store, file, "strip", {});
  const auto entry = store.find("strip");
  ASSERT_TRUE(entry);

  warp::View view;
  add_quad(view, 100, 200, 0);
  add_quad(view, 39600, 200, 200);
  tiles::PyramidReader reader(16 << 20);
  const tiles::Raster screen = warp::render_view(view, 400, kHeight, *entry, reader);

  for (int x = 2; x < 398; x += 7) {
    const double source_x = x < 200 ? 100 + x + 0.5 : 39600 + (x - 200) + 0.5;
    SCOPED_TRACE(::testing::Message() << "screen x " << x << ", source x " << source_x);
    EXPECT_NEAR(screen.row(kHeight / 2)[3 * x], ramp(source_x), 2.0);
  }
}

}  // namespace
}  // namespace zoomwarp
