// The judges of issue 41's measures (warp/compare/): the independent saliency model finds what
// stands out where it is, on its own thumbnail; the attention smart crop goes where skin,
// saturated colour and edges are. Plain images made here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "warp/compare/independent_saliency.h"
#include "warp/compare/smart_crop.h"

namespace zoomwarp {
namespace {

// A w × h RGB image of flat grey with a filled w/10-wide square of `rgb` centred at (cx, cy).
tiles::Raster grey_with_square(int w, int h, int cx, int cy, std::array<std::uint8_t, 3> rgb) {
  tiles::Raster r(w, h, 3);
  std::fill(r.pixels.begin(), r.pixels.end(), std::uint8_t(128));
  const int half = w / 20;
  for (int y = std::max(0, cy - half); y < std::min(h, cy + half); ++y)
    for (int x = std::max(0, cx - half); x < std::min(w, cx + half); ++x)
      for (int c = 0; c < 3; ++c) r.row(y)[std::size_t(x) * 3 + c] = rgb[c];
  return r;
}

// A dark disc on a light, finely grained background (a product shot): what stands out is the
// disc. The grain (deterministic, ±8) keeps the spectrum free of exact zeros, where a log
// amplitude would be a cliff rather than a measure.
TEST(IndependentSaliency, FindsWhatStandsOutOnAThumbnailOfItsOwn) {
  const int w = 512, h = 256, cx = 400, cy = 96, r = 24;
  const auto in_disc = [&](double x, double y, double margin) { return std::hypot(x - cx, y - cy) < r + margin; };
  tiles::Raster image(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int grain = int((x * 7919L + y * 104729L) % 17) - 8;
      const int v = (in_disc(x, y, 0) ? 40 : 200) + grain;
      for (int c = 0; c < 3; ++c) image.row(y)[std::size_t(x) * 3 + c] = std::uint8_t(v);
    }
  const warp::SignificanceMap m = warp::independent_saliency(image, 2048);  // a 2048 px wide image
  ASSERT_EQ(m.width, 128);
  ASSERT_EQ(m.height, 64);
  EXPECT_DOUBLE_EQ(m.scale, 128.0 / 2048);
  const auto top = std::max_element(m.values.begin(), m.values.end());
  EXPECT_FLOAT_EQ(*top, 1.0f);
  const int at = int(top - m.values.begin()), x = at % m.width, y = at / m.width;
  EXPECT_TRUE(in_disc(x * 4 + 2, y * 4 + 2, 8)) << "the peak at thumbnail (" << x << ", " << y << ")";
  double inside = 0, outside = 0;
  int n_inside = 0, n_outside = 0;
  for (int ty = 0; ty < m.height; ++ty)
    for (int tx = 0; tx < m.width; ++tx) {
      const float v = m.values[std::size_t(ty) * m.width + tx];
      if (in_disc(tx * 4 + 2, ty * 4 + 2, 8)) inside += v, ++n_inside;
      else outside += v, ++n_outside;
    }
  EXPECT_GT(inside / n_inside, 10 * outside / n_outside);
  EXPECT_TRUE(warp::independent_saliency(tiles::Raster(), 100).values.empty());
  // Grey with alpha, a sliver and a 1 × 1 image: a map of their own size at most, no crash.
  EXPECT_EQ(warp::independent_saliency(tiles::Raster(7, 300, 2), 7).height, 128);
  EXPECT_EQ(warp::independent_saliency(tiles::Raster(1, 1, 3), 1).values.size(), 1u);
}

TEST(SmartCrop, CentresTheCropWhereAttentionIs) {
  // A saturated red square near the right of a 2:1 grey picture, on a 9:16 phone: the crop (the
  // picture's height, 0.5625 of it wide) goes over the square.
  const tiles::Raster image = grey_with_square(800, 400, 650, 200, {230, 20, 20});
  const warp::Point c = warp::attention_crop_centre(image, 4000, 2000, 360, 640);
  const double crop_w = 2000 * 360.0 / 640;
  EXPECT_NEAR(c.x, 650 * 5, crop_w / 4);
  EXPECT_NEAR(c.y, 1000, 1e-9);  // the crop's height is the picture's
  EXPECT_LE(c.x + crop_w / 2, 4000 + 1e-9);
  // At the border it is clipped to the picture.
  const warp::Point edge = warp::attention_crop_centre(grey_with_square(800, 400, 790, 200, {230, 20, 20}), 4000, 2000, 360, 640);
  EXPECT_NEAR(edge.x, 4000 - crop_w / 2, 1e-6);
  // An empty image: the middle.
  const warp::Point none = warp::attention_crop_centre(tiles::Raster(), 4000, 2000, 360, 640);
  EXPECT_EQ(none.x, 2000);
  EXPECT_EQ(none.y, 1000);
}

}  // namespace
}  // namespace zoomwarp
