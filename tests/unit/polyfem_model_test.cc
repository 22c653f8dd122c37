// method=polyfem's model (warp/methods/polyfem/polyfem_retargeter.h: polyfem.<saliency>.bin) as
// ingest builds it and the engine reads it back: the bytes round-trip exactly and give the same
// views; damaged bytes are refused with an error, never half-read; images at the edges of the
// input space (1×1, 3×3, 2×2000, a fine checkerboard whose GBVS map has edges everywhere) all get
// a model and a view.
#include <gtest/gtest.h>

#include <cstdio>
#include <stdexcept>
#include <string>

#include "tests/support/analysed_image.h"
#include "warp/meshing/cvt_mesh.h"
#include "warp/methods/polyfem/polyfem_retargeter.h"

namespace zoomwarp {
namespace {

using warp::PolyfemModel;
using warp::PolyfemRetargeting;

tiles::Raster checkerboard(int w, int h, int square) {
  tiles::Raster r(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::uint8_t v = ((x / square + y / square) % 2) ? 230 : 20;
      for (int c = 0; c < 3; ++c) r.row(y)[3 * x + c] = v;
    }
  return r;
}

PolyfemModel model_of(const testing::AnalysedImage& image, warp::Saliency kind = warp::Saliency::kDefault) {
  const warp::SignificanceMap map = image.saliency(kind);
  return warp::build_polyfem_model(image.input(kind, map));
}

// No inverted triangle, and the view covers its screen's centre.
void expect_sound_view(PolyfemRetargeting& r, double width, double height, int sw, int sh, double zoom) {
  warp::ViewRequest q;
  q.screen_width = sw, q.screen_height = sh, q.zoom = zoom, q.cx = width / 2, q.cy = height / 2;
  const warp::View v = r.view(q);
  ASSERT_FALSE(v.source.triangles.empty());
  for (const auto& t : v.source.triangles) EXPECT_GT(warp::signed_area2(v.warped[t[0]], v.warped[t[1]], v.warped[t[2]]), 0);
}

TEST(PolyfemModel, BytesRoundTripExactlyAndGiveTheSameViews) {
  const testing::AnalysedImage image = testing::analyse_sample("boats_lake_sunset.jpg");
  const PolyfemModel m = model_of(image);
  const std::string bytes = warp::polyfem_model_bytes(m);
  const PolyfemModel back = warp::parse_polyfem_model(bytes);
  EXPECT_EQ(warp::polyfem_model_bytes(back), bytes);
  EXPECT_EQ(back.solution.g_x, m.solution.g_x);
  EXPECT_EQ(back.solution.stiffness.value, m.solution.stiffness.value);
  EXPECT_EQ(back.fold_free.low, m.fold_free.low);
  EXPECT_EQ(back.fold_free.high, m.fold_free.high);
  const double W = image.model.width, H = image.model.height;
  PolyfemRetargeting a(W, H, m), b(W, H, back);
  warp::ViewRequest q;
  q.screen_width = 360, q.screen_height = 640, q.zoom = 0.5, q.cx = W / 3, q.cy = H / 2;
  const warp::View va = a.view(q), vb = b.view(q);
  ASSERT_EQ(va.screen.size(), vb.screen.size());
  for (std::size_t i = 0; i < va.screen.size(); ++i) {
    EXPECT_EQ(va.screen[i].x, vb.screen[i].x);
    EXPECT_EQ(va.screen[i].y, vb.screen[i].y);
  }
}

// Every truncation, and a fold-free range that excludes the identity, are refused.
TEST(PolyfemModel, DamagedBytesAreRefused) {
  const PolyfemModel m = model_of(testing::analyse_sample("astronaut_portrait.png"));
  const std::string bytes = warp::polyfem_model_bytes(m);
  for (std::size_t cut = 0; cut < bytes.size(); cut += 1 + bytes.size() / 97)
    EXPECT_THROW(warp::parse_polyfem_model(bytes.substr(0, cut)), std::runtime_error) << "cut at " << cut;
  EXPECT_THROW(warp::parse_polyfem_model(bytes + "x"), std::runtime_error);
  PolyfemModel bad = m;
  bad.fold_free.high = 0.9;
  EXPECT_THROW(warp::parse_polyfem_model(warp::polyfem_model_bytes(bad)), std::runtime_error);
}

// A 7-px checkerboard: its GBVS map has edges everywhere and [PolyFEM eq. 10]'s descent cannot
// remove every short edge (ingest refused the image before); the model falls back to the
// unweighted CVT instead.
TEST(PolyfemModel, AnImageWithEdgesEverywhereStillGetsAModel) {
  const testing::AnalysedImage image = testing::analyse_image(checkerboard(600, 400, 7));
  const warp::SignificanceMap map = image.saliency(warp::Saliency::kGbvs);
  EXPECT_THROW(warp::build_cvt_mesh(map.values, map.width, map.height, image.analysis.width, image.analysis.height),
               std::runtime_error);
  const PolyfemModel m = model_of(image, warp::Saliency::kGbvs);
  EXPECT_GE(m.mesh.cells.size(), 190u);
  PolyfemRetargeting r(image.model.width, image.model.height, m);
  expect_sound_view(r, image.model.width, image.model.height, 360, 640, 0);
}

TEST(PolyfemModel, TinyAndThinImagesGetAModelAndAView) {
  struct Size {
    int w, h;
  };
  for (const Size s : {Size{1, 1}, Size{3, 3}, Size{2, 2000}, Size{2000, 2}}) {
    SCOPED_TRACE(std::to_string(s.w) + "x" + std::to_string(s.h));
    const testing::AnalysedImage image = testing::analyse_image(checkerboard(s.w, s.h, 1));
    const PolyfemModel m = model_of(image);
    EXPECT_GE(m.mesh.cells.size(), 1u);
    PolyfemRetargeting r(image.model.width, image.model.height, m);
    for (double zoom : {0.0, 1.0}) {
      expect_sound_view(r, image.model.width, image.model.height, 360, 640, zoom);
      expect_sound_view(r, image.model.width, image.model.height, 640, 360, zoom);
    }
  }
}

}  // namespace
}  // namespace zoomwarp
