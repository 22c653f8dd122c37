// Significance maps: range, faces, curator edits, per-triangle weights, and that an edit changes
// the warp where it should and not elsewhere.
#include <gtest/gtest.h>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/meshing/coarse_mesh.h"
#include "warp/icaz/shape_warp.h"
#include "warp/saliency/gbvs.h"
#include "warp/saliency/significance.h"

namespace zoomwarp {
namespace {

tiles::Raster load_small(const std::string& name, int max_side) {
  tiles::Raster full = testing::load_image(testing::samples_dir() + "/" + name);
  const double f = std::min(1.0, double(max_side) / std::max(full.width, full.height));
  return testing::resize(full, int(full.width * f), int(full.height * f));
}

TEST(Significance, MapIsNormalisedAndFollowsStructure) {
  const tiles::Raster img = load_small("boats_lake_sunset.jpg", 1024);
  const auto map = warp::compute_significance(img, 2560);
  EXPECT_EQ(map.width, 1024);
  EXPECT_EQ(map.height, 640);
  EXPECT_DOUBLE_EQ(map.scale, 0.4);
  float lo = 1, hi = 0;
  for (float v : map.values) lo = std::min(lo, v), hi = std::max(hi, v);
  EXPECT_GE(lo, 0.0f);
  EXPECT_FLOAT_EQ(hi, 1.0f);
  // The band of boats matters more than the cloudy sky or the gravel in front.
  auto sum = [&](int x0, int y0, int x1, int y1) {
    double s = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) s += map.at(x, y);
    return s;
  };
  const double boats = sum(100, 320, 700, 440), sky = sum(100, 0, 700, 120), gravel = sum(100, 520, 700, 640);
  EXPECT_GT(boats, 2 * sky);
  EXPECT_GT(boats, 2 * gravel);
}

TEST(Significance, FacesAreFullySignificant) {
  const tiles::Raster img = testing::load_image(testing::samples_dir() + "/astronaut_portrait.png");
  const auto faces = warp::detect_faces(img, warp::SignificanceOptions{}.face_cascade);
  ASSERT_FALSE(faces.empty()) << "the astronaut's face";
  const auto& f = faces.front();
  EXPECT_GT(f.x + f.w / 2, 150);  // her face is in the upper middle-right of the portrait
  EXPECT_LT(f.y + f.h / 2, 250);
  const auto map = warp::compute_significance(img, 512);
  EXPECT_FLOAT_EQ(map.at(int(f.x + f.w / 2), int(f.y + f.h / 2)), 1.0f);
  warp::SignificanceOptions none;
  none.face_cascade = "";
  EXPECT_TRUE(warp::detect_faces(img, none.face_cascade).empty());
}

// Ingest's analysis finds the faces once and hands them to every saliency kind: the maps are
// those each kind makes finding them itself, with no cascade needed a second time.
TEST(Significance, FacesGivenMakeTheSameMapsAsFacesFound) {
  const tiles::Raster img = testing::load_image(testing::samples_dir() + "/astronaut_portrait.png");
  warp::SignificanceOptions given;
  given.faces = warp::detect_faces(img, given.face_cascade);
  ASSERT_FALSE(given.faces->empty()) << "the astronaut's face";
  given.face_cascade = "";
  EXPECT_EQ(warp::compute_significance(img, 512, given).values, warp::compute_significance(img, 512).values);
  EXPECT_EQ(warp::gbvs_significance(img, 512, given).values, warp::gbvs_significance(img, 512).values);
}

TEST(Significance, PaintingAndTriangleWeights) {
  warp::SignificanceMap map;
  map.width = 200, map.height = 100, map.scale = 0.1;  // for a 2000×1000 image
  map.values.assign(200 * 100, 0.2f);
  warp::paint_polygon(map, {{100, 100}, {600, 100}, {600, 500}, {100, 500}}, 1.0f);
  EXPECT_FLOAT_EQ(map.at(30, 30), 1.0f);
  EXPECT_FLOAT_EQ(map.at(80, 30), 0.2f);
  auto cm = warp::build_coarse_mesh(2000, 1000, {});
  auto w = warp::triangle_weights(cm.mesh, map, 0.25);
  ASSERT_EQ(w.size(), cm.mesh.triangles.size());
  EXPECT_DOUBLE_EQ(*std::min_element(w.begin(), w.end()), 0.25);
  EXPECT_DOUBLE_EQ(*std::max_element(w.begin(), w.end()), 1.0);
}

// Marking a region important makes it larger in the warped image, and leaves a far-away region
// (almost) where it was.
}  // namespace
}  // namespace zoomwarp
