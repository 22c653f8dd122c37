// method=patch's patches (warp/methods/patch/patch_segmentation.h): Felzenszwalb–Huttenlocher on
// images with known regions, then [Lin13 §III-B]'s merging — what METHODS' tests ask: after
// merging no patch under 0.01 % of the image and no adjacent pair closer than 20 in mean RGB.
#include "warp/methods/patch/patch_segmentation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <set>

#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

// A w × h RGB image painted by f(x, y) → {r, g, b}.
template <class F>
tiles::Raster painted(int w, int h, F f) {
  tiles::Raster r(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto c = f(x, y);
      for (int k = 0; k < 3; ++k) r.row(y)[3 * x + k] = std::uint8_t(c[k]);
    }
  return r;
}

double colour_distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

void expect_merged(const warp::Patches& p, const warp::SegmentationOptions& o = {}) {
  ASSERT_EQ(p.label.size(), std::size_t(p.width) * p.height);
  std::vector<int> count(p.count, 0);
  for (int l : p.label) {
    ASSERT_GE(l, 0);
    ASSERT_LT(l, p.count);
    ++count[l];
  }
  EXPECT_EQ(count, p.size);
  const auto adjacency = warp::patch_adjacency(p);
  for (int a = 0; a < p.count; ++a) {
    if (p.count > 1) {
      EXPECT_GE(p.size[a], o.min_fraction * p.width * p.height) << "patch " << a;
    }
    for (int b : adjacency[a])
      EXPECT_GE(colour_distance(p.mean_colour[a], p.mean_colour[b]), o.merge_distance) << a << " next to " << b;
  }
}

TEST(PatchSegmentation, TwoFlatHalvesAreTwoPatches) {
  const tiles::Raster img = painted(80, 60, [](int x, int) { return std::array{x < 40 ? 200 : 30, 90, 60}; });
  const warp::Patches p = warp::segment_patches(img);
  expect_merged(p);
  ASSERT_EQ(p.count, 2);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) EXPECT_EQ(p.label[y * 80 + x], x < 40 ? 0 : 1) << x << ", " << y;
  EXPECT_NEAR(p.mean_colour[0][0], 200, 1e-9);
  EXPECT_NEAR(p.mean_colour[1][0], 30, 1e-9);
}

// Halves 10 apart in red are several components for the graph at a small k (the smoothed seam
// between them is a strip of its own), one patch after merging (closer than 20); 30 apart they
// stay two.
TEST(PatchSegmentation, SimilarNeighboursMergeDistinctOnesDoNot) {
  warp::SegmentationOptions o;
  o.k = 1;
  for (int step : {10, 30}) {
    const tiles::Raster img = painted(80, 60, [&](int x, int) { return std::array{x < 40 ? 100 : 100 + step, 90, 60}; });
    EXPECT_GE(warp::segment_graph(img, o).count, 2) << step;
    const warp::Patches p = warp::segment_patches(img, o);
    expect_merged(p, o);
    EXPECT_EQ(p.count, step < 20 ? 1 : 2) << step;
  }
}

// Specks of 1 px (under 0.01 % of a 200 × 200 image: 4 px) join the patch around them.
TEST(PatchSegmentation, SmallPatchesJoinTheirNearestNeighbour) {
  warp::SegmentationOptions o;
  o.min_size = 1;  // let the graph keep the specks, so that the merge must remove them
  o.k = 1;
  const tiles::Raster img = painted(200, 200, [](int x, int y) {
    if (x % 50 == 25 && y % 50 == 25) return std::array{250, 250, 250};
    return x < 100 ? std::array{20, 20, 200} : std::array{200, 20, 20};
  });
  EXPECT_GT(warp::segment_graph(img, o).count, 2);
  const warp::Patches p = warp::segment_patches(img, o);
  expect_merged(p, o);
  EXPECT_EQ(p.count, 2);
}

TEST(PatchSegmentation, DegenerateImages) {
  EXPECT_EQ(warp::segment_patches(tiles::Raster()).count, 0);
  for (auto [w, h] : {std::pair{1, 1}, {1, 500}, {500, 1}, {2, 2}}) {
    const warp::Patches p = warp::segment_patches(painted(w, h, [](int x, int y) { return std::array{(x * 37) % 256, (y * 91) % 256, 7}; }));
    expect_merged(p);
    EXPECT_GE(p.count, 1) << w << " x " << h;
  }
  tiles::Raster grey(30, 20, 1);
  for (int i = 0; i < 600; ++i) grey.pixels[i] = std::uint8_t(i % 30 < 15 ? 10 : 240);
  EXPECT_EQ(warp::segment_patches(grey).count, 2);
}

// The samples at analysis size: patch counts before and after merging, and the time.
TEST(PatchSegmentation, Samples) {
  for (const char* file : {"boats_lake_sunset.jpg", "astronaut_portrait.png", "pano_grossmugl_field_4to1.png"}) {
    const tiles::Raster full = testing::load_image(testing::samples_dir() + "/" + file);
    const double f = std::min(1.0, 1024.0 / std::max(full.width, full.height));
    const tiles::Raster small = testing::resize(full, int(full.width * f), int(full.height * f));
    const auto t0 = std::chrono::steady_clock::now();
    const warp::Patches graph = warp::segment_graph(small);
    const auto t1 = std::chrono::steady_clock::now();
    const warp::Patches merged = warp::merge_patches(graph);
    const auto t2 = std::chrono::steady_clock::now();
    SCOPED_TRACE(file);
    expect_merged(merged);
    std::printf("[ patches  ] %-32s %4dx%-4d %5d components (%.0f ms), %4d patches after merging (%.0f ms)\n", file,
                small.width, small.height, graph.count, std::chrono::duration<double, std::milli>(t1 - t0).count(),
                merged.count, std::chrono::duration<double, std::milli>(t2 - t1).count());
    EXPECT_LT(merged.count, graph.count);
  }
}

}  // namespace
}  // namespace zoomwarp
