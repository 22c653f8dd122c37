// IIIF Image API 3.0 request planning against sizes computed by hand from the specification.
#include <gtest/gtest.h>

#include "api/errors.h"
#include "api/iiif.h"

namespace zoomwarp {
namespace {

using api::IiifPlan;

constexpr int W = 2560, H = 1600;  // the sample image
const api::IiifLimits kLimits{4000, 3000, 4000LL * 2500};

IiifPlan plan(const char* region, const char* size, const char* rotation = "0",
              const char* qf = "default.jpg") {
  return api::plan_iiif_request(region, size, rotation, qf, W, H, kLimits);
}

int status_of(const char* region, const char* size, const char* rotation = "0",
              const char* qf = "default.jpg") {
  try {
    plan(region, size, rotation, qf);
  } catch (const api::ApiError& e) {
    return e.status();
  }
  return 200;
}

struct Expect {
  const char *region, *size;
  long long x, y, w, h;  // region
  int out_w, out_h;
};

TEST(Iiif, RegionAndSizeTable) {
  const Expect table[] = {
      {"full", "max", 0, 0, 2560, 1600, 2560, 1600},
      {"square", "max", 480, 0, 1600, 1600, 1600, 1600},
      {"0,0,256,256", "max", 0, 0, 256, 256, 256, 256},
      {"2048,1536,1024,1024", "max", 2048, 1536, 512, 64, 512, 64},  // clipped at the edges
      {"pct:10,10,50,50", "max", 256, 160, 1280, 800, 1280, 800},
      {"pct:0,0,100,100", "pct:50", 0, 0, 2560, 1600, 1280, 800},
      {"full", "640,", 0, 0, 2560, 1600, 640, 400},
      {"full", ",400", 0, 0, 2560, 1600, 640, 400},
      {"full", "333,", 0, 0, 2560, 1600, 333, 208},  // 1600 * 333 / 2560 = 208.1
      {"full", "100,100", 0, 0, 2560, 1600, 100, 100},
      {"full", "!800,800", 0, 0, 2560, 1600, 800, 500},
      {"full", "!300,1000", 0, 0, 2560, 1600, 300, 188},  // 187.5 rounds to 188
      {"0,0,100,50", "^200,", 0, 0, 100, 50, 200, 100},
      {"0,0,100,50", "^pct:300", 0, 0, 100, 50, 300, 150},
      {"0,0,100,50", "^!1000,1000", 0, 0, 100, 50, 1000, 500},
      {"0,0,100,50", "^max", 0, 0, 100, 50, 4000, 2000},  // maxWidth binds: 40× (area allows 44.7×)
      {"full", "^max", 0, 0, 2560, 1600, 4000, 2500},     // 1.5625×: maxWidth and maxArea both bind
      {"0,0,1,1", "max", 0, 0, 1, 1, 1, 1},
  };
  for (const Expect& e : table) {
    const IiifPlan p = plan(e.region, e.size);
    EXPECT_EQ(p.region, (tiles::Rect{e.x, e.y, e.w, e.h})) << e.region << " " << e.size;
    EXPECT_EQ(p.width, e.out_w) << e.region << " " << e.size;
    EXPECT_EQ(p.height, e.out_h) << e.region << " " << e.size;
  }
}

TEST(Iiif, MaxIsLimitedByServerLimits) {
  const api::IiifLimits small{1000, 1000, 1000LL * 1000};
  auto p = api::plan_iiif_request("full", "max", "0", "default.png", W, H, small);
  EXPECT_EQ(p.width, 1000);
  EXPECT_EQ(p.height, 625);
  EXPECT_LE(p.width * p.height, 1000 * 1000);
}

TEST(Iiif, RotationMirrorQualityFormat) {
  auto p = plan("full", "max", "!90", "gray.png");
  EXPECT_TRUE(p.mirror);
  EXPECT_EQ(p.rotation, 90);
  EXPECT_EQ(p.quality, api::IiifQuality::kGray);
  EXPECT_EQ(p.format, tiles::ImageFormat::kPng);
  EXPECT_EQ(plan("full", "max", "360", "bitonal.webp").rotation, 0);
  EXPECT_EQ(plan("full", "max", "270.0", "color.jpg").rotation, 270);
  EXPECT_EQ(plan("full", "max", "180", "default.webp").format, tiles::ImageFormat::kWebp);
}

TEST(Iiif, ErrorsUseTheSpecifiedStatus) {
  // 400: malformed or impossible.
  for (auto [r, s, rot, qf] : std::initializer_list<std::array<const char*, 4>>{
           {"ful", "max", "0", "default.jpg"},           {"0,0,0,10", "max", "0", "default.jpg"},
           {"0,0,10", "max", "0", "default.jpg"},        {"-1,0,10,10", "max", "0", "default.jpg"},
           {"3000,0,10,10", "max", "0", "default.jpg"},  {"pct:100,0,10,10", "max", "0", "default.jpg"},
           {"pct:a,0,10,10", "max", "0", "default.jpg"}, {"1e3,0,10,10", "max", "0", "default.jpg"},
           {"full", "0,", "0", "default.jpg"},           {"full", ",", "0", "default.jpg"},
           {"full", "3000,", "0", "default.jpg"},        {"full", "pct:101", "0", "default.jpg"},
           {"full", "pct:0", "0", "default.jpg"},        {"full", "!10,", "0", "default.jpg"},
           {"full", "^5000,", "0", "default.jpg"},       {"full", "nan,", "0", "default.jpg"},
           {"full", "99999999999,", "0", "default.jpg"}, {"full", "max", "-90", "default.jpg"},
           {"full", "max", "400", "default.jpg"},        {"full", "max", "abc", "default.jpg"},
           {"full", "max", "nan", "default.jpg"},        {"full", "max", "0", "sepia.jpg"},
           {"full", "max", "0", "default"},              {"full", "max", "0", "default.exe"},
           {"full", "max", "0", "default.jpeg"}}) {
    EXPECT_EQ(status_of(r, s, rot, qf), 400) << r << "/" << s << "/" << rot << "/" << qf;
  }
  // 501: well-formed, not offered.
  EXPECT_EQ(status_of("full", "max", "22.5"), 501);
  EXPECT_EQ(status_of("full", "max", "0", "default.tif"), 501);
  EXPECT_EQ(status_of("full", "max", "0", "default.gif"), 501);
}

}  // namespace
}  // namespace zoomwarp
