// Deep Zoom tile geometry: level numbering from 1×1, overlap, edge tiles.
#include <gtest/gtest.h>

#include "api/deepzoom.h"
#include "api/url.h"
#include "tiles/byte_lru_cache.h"

namespace zoomwarp {
namespace {

tiles::Manifest sample() {
  tiles::Manifest m;
  m.id = "s";
  m.width = 2560;
  m.height = 1600;
  m.levels = tiles::pyramid_levels(2560, 1600);
  return m;
}

TEST(DeepZoom, LevelsCountFromOnePixel) {
  const auto m = sample();
  EXPECT_EQ(m.levels, 13);  // ceil(log2(2560)) + 1
  api::DziLayout layout;
  auto top = api::dzi_tile(m, layout, 0, 0, 0);
  ASSERT_TRUE(top);
  EXPECT_EQ(top->store_level, 12);
  EXPECT_EQ(top->rect, (tiles::Rect{0, 0, 1, 1}));
  EXPECT_FALSE(api::dzi_tile(m, layout, 0, 1, 0));
  EXPECT_FALSE(api::dzi_tile(m, layout, 13, 0, 0));
}

TEST(DeepZoom, TilesOverlapTheirNeighbours) {
  const auto m = sample();
  api::DziLayout layout;  // 254 + 1 overlap
  auto first = api::dzi_tile(m, layout, 12, 0, 0);
  EXPECT_EQ(first->rect, (tiles::Rect{0, 0, 255, 255}));
  auto inner = api::dzi_tile(m, layout, 12, 1, 1);
  EXPECT_EQ(inner->rect, (tiles::Rect{253, 253, 256, 256}));
  // Last column: 2560 = 10 × 254 + 20, so column 10 holds 20 pixels plus the overlap on its left.
  auto last = api::dzi_tile(m, layout, 12, 10, 6);
  EXPECT_EQ(last->rect, (tiles::Rect{2539, 1523, 21, 77}));
  EXPECT_FALSE(api::dzi_tile(m, layout, 12, 11, 0));
  EXPECT_FALSE(api::dzi_tile(m, layout, 12, 0, 7));
  // Level 11 is 1280×800 (store level 1).
  auto half = api::dzi_tile(m, layout, 11, 5, 3);
  EXPECT_EQ(half->store_level, 1);
  EXPECT_EQ(half->rect, (tiles::Rect{1269, 761, 11, 39}));
}

TEST(Url, StrictParsing) {
  EXPECT_EQ(api::percent_decode("a%2Fb"), "a/b");
  EXPECT_FALSE(api::percent_decode("a%2"));
  EXPECT_FALSE(api::percent_decode("a%zz"));
  EXPECT_FALSE(api::percent_decode("a%00b"));
  auto segs = api::split_path("/iiif/3/x%20y/info.json");
  ASSERT_TRUE(segs);
  EXPECT_EQ((*segs)[2], "x y");
  EXPECT_FALSE(api::split_path("relative"));
  EXPECT_EQ(api::parse_small_uint("007"), 7);
  for (const char* bad : {"", "-1", "+1", "1e3", "0x10", " 1", "1234567890", "1.0"})
    EXPECT_FALSE(api::parse_small_uint(bad)) << bad;
  EXPECT_EQ(api::parse_plain_decimal(".5"), 0.5);
  for (const char* bad : {"", ".", "nan", "inf", "1e5", "-1", "1..2", "1,5"})
    EXPECT_FALSE(api::parse_plain_decimal(bad)) << bad;
  auto q = api::parse_query("id=a%20b&x=&y");
  ASSERT_TRUE(q);
  EXPECT_EQ((*q)[0].second, "a b");
  EXPECT_FALSE(api::parse_query("=v"));
}

TEST(ByteLruCache, EvictsLeastRecentlyUsedWithinTheByteBudget) {
  tiles::ByteLruCache<std::string> cache(8000);
  for (int i = 0; i < 20; ++i) cache.put("k" + std::to_string(i), std::make_shared<std::string>(600, 'x'), 600);
  auto s = cache.stats();
  EXPECT_LE(s.bytes, 8000u);
  EXPECT_GT(s.evictions, 0u);
  EXPECT_FALSE(cache.get("k0"));
  EXPECT_TRUE(cache.get("k19"));
  cache.put("huge", std::make_shared<std::string>(5000, 'x'), 5000);  // over 1/8 of the budget
  EXPECT_FALSE(cache.get("huge"));
}

}  // namespace
}  // namespace zoomwarp
