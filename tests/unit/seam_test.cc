// Seam carving (method=seam, warp/methods/seam/): the visibility maps liblqr records, the carve
// tables made from them against liblqr's own resize, nesting, the saliency bias, degenerate
// images, the model file's bytes, the reduced resolution seams are carved at, and the carved
// image's geometry (identity at equal aspects, the target sizes, the view centre carried through).
#include <gtest/gtest.h>
#include <lqr.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/methods/retargeting_method.h"
#include "warp/methods/seam/seam_carving.h"
#include "warp/methods/seam/seam_resolution.h"
#include "warp/methods/seam/visibility_map.h"
#include "warp/saliency/significance.h"

namespace zoomwarp {
namespace {

using warp::CarveTable;
using warp::VisibilityMap;
using warp::VisibilityMaps;

tiles::Raster boats(int width, int height) {
  return testing::resize(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"), width, height);
}

warp::SignificanceMap significance_of(const tiles::Raster& image) {
  warp::SignificanceOptions no_faces;
  no_faces.face_cascade = "";
  return warp::compute_significance(image, image.width, no_faces);
}

// liblqr carving `image` to w × h on a fresh carver set up as compute_visibility_maps does
// (seams ≤ 1 px sideways, no rigidity, gradient-norm energy, the saliency bias): the oracle.
tiles::Raster lqr_resized(const tiles::Raster& image, const warp::SignificanceMap& saliency, int bias_factor, int w,
                          int h) {
  std::vector<guchar> pixels(image.pixels.begin(), image.pixels.end());
  std::unique_ptr<LqrCarver, decltype(&lqr_carver_destroy)> c(
      lqr_carver_new(pixels.data(), image.width, image.height, image.channels), &lqr_carver_destroy);
  EXPECT_TRUE(c);
  lqr_carver_set_preserve_input_image(c.get());
  EXPECT_EQ(lqr_carver_init(c.get(), 1, 0), LQR_OK);
  EXPECT_EQ(lqr_carver_set_energy_function_builtin(c.get(), LQR_EF_GRAD_NORM), LQR_OK);
  std::vector<gdouble> bias(saliency.values.begin(), saliency.values.end());
  EXPECT_EQ(lqr_carver_bias_add(c.get(), bias.data(), bias_factor), LQR_OK);
  EXPECT_EQ(lqr_carver_resize(c.get(), w, h), LQR_OK);
  tiles::Raster out(lqr_carver_get_width(c.get()), lqr_carver_get_height(c.get()), image.channels);
  lqr_carver_scan_reset(c.get());
  gint x, y;
  guchar* rgb;
  while (lqr_carver_scan(c.get(), &x, &y, &rgb)) std::copy_n(rgb, image.channels, out.row(y) + x * image.channels);
  return out;
}

// The pixels our carve table keeps, in order: what the carved analysis image looks like.
tiles::Raster kept_pixels(const tiles::Raster& image, const CarveTable& t, bool vertical) {
  const int c = image.channels;
  tiles::Raster out(vertical ? image.width : t.kept, vertical ? t.kept : image.height, c);
  for (int l = 0; l < t.lines; ++l)
    for (int j = 0; j < t.kept; ++j) {
      const int p = t.line(l)[j];
      const std::uint8_t* from = vertical ? image.row(p) + l * c : image.row(l) + p * c;
      std::copy_n(from, c, vertical ? out.row(j) + l * c : out.row(l) + j * c);
    }
  return out;
}

// Every line holds each of 1 … depth exactly once, the rest 0: counted here, independently of
// check_visibility_map.
void expect_map_format(const VisibilityMap& m, int length, int lines) {
  ASSERT_EQ(m.length, length);
  ASSERT_EQ(m.lines, lines);
  EXPECT_EQ(m.depth, length * 9 / 10);
  ASSERT_EQ(m.order.size(), std::size_t(length) * lines);
  for (int l = 0; l < lines; ++l) {
    std::vector<int> count(m.depth + 1, 0);
    for (int p = 0; p < length; ++p) {
      ASSERT_LE(m.at(l, p), m.depth);
      ++count[m.at(l, p)];
    }
    EXPECT_EQ(count[0], length - m.depth) << "line " << l;
    for (int v = 1; v <= m.depth; ++v) ASSERT_EQ(count[v], 1) << "line " << l << " value " << v;
  }
}

class SeamMaps : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    image_ = new tiles::Raster(boats(160, 100));
    saliency_ = new warp::SignificanceMap(significance_of(*image_));
    maps_ = new VisibilityMaps(warp::compute_visibility_maps(*image_, *saliency_));
  }
  static void TearDownTestSuite() {
    delete maps_;
    delete saliency_;
    delete image_;
  }
  static tiles::Raster* image_;
  static warp::SignificanceMap* saliency_;
  static VisibilityMaps* maps_;
};
tiles::Raster* SeamMaps::image_ = nullptr;
warp::SignificanceMap* SeamMaps::saliency_ = nullptr;
VisibilityMaps* SeamMaps::maps_ = nullptr;

TEST_F(SeamMaps, EveryLineHoldsEachSeamOnce) {
  expect_map_format(maps_->horizontal, 160, 100);
  expect_map_format(maps_->vertical, 100, 160);
  EXPECT_EQ(warp::check_visibility_map(maps_->horizontal), "");
  EXPECT_EQ(warp::check_visibility_map(maps_->vertical), "");
}

TEST_F(SeamMaps, CarveTablesEqualLiblqrsResizePixelForPixel) {
  for (int k : {1, 17, 80, 144}) {
    SCOPED_TRACE(k);
    const tiles::Raster ours = kept_pixels(*image_, warp::carve(maps_->horizontal, k), false);
    const tiles::Raster lqr = lqr_resized(*image_, *saliency_, warp::kSaliencyBiasFactor, 160 - k, 100);
    ASSERT_EQ(ours.width, lqr.width);
    EXPECT_EQ(ours.pixels, lqr.pixels);
  }
  for (int k : {1, 45, 90}) {
    SCOPED_TRACE(k);
    const tiles::Raster ours = kept_pixels(*image_, warp::carve(maps_->vertical, k), true);
    const tiles::Raster lqr = lqr_resized(*image_, *saliency_, warp::kSaliencyBiasFactor, 160, 100 - k);
    ASSERT_EQ(ours.height, lqr.height);
    EXPECT_EQ(ours.pixels, lqr.pixels);
  }
}

// liblqr reading our stored map back (lqr_vmap_load) carves exactly as our tables do.
TEST_F(SeamMaps, LiblqrLoadingTheStoredMapCarvesAsOurTables) {
  const VisibilityMap& m = maps_->horizontal;
  gint* buffer = g_new(gint, m.order.size());
  std::copy(m.order.begin(), m.order.end(), buffer);
  LqrVMap* vmap = lqr_vmap_new(buffer, m.length, m.lines, m.depth, 0);
  ASSERT_TRUE(vmap);
  for (int k : {5, 60, 144}) {
    SCOPED_TRACE(k);
    std::vector<guchar> pixels(image_->pixels.begin(), image_->pixels.end());
    std::unique_ptr<LqrCarver, decltype(&lqr_carver_destroy)> c(
        lqr_carver_new(pixels.data(), image_->width, image_->height, image_->channels), &lqr_carver_destroy);
    lqr_carver_set_preserve_input_image(c.get());
    ASSERT_EQ(lqr_vmap_load(c.get(), vmap), LQR_OK);
    ASSERT_EQ(lqr_carver_resize(c.get(), m.length - k, m.lines), LQR_OK);
    tiles::Raster lqr(m.length - k, m.lines, image_->channels);
    lqr_carver_scan_reset(c.get());
    gint x, y;
    guchar* rgb;
    while (lqr_carver_scan(c.get(), &x, &y, &rgb)) std::copy_n(rgb, lqr.channels, lqr.row(y) + x * lqr.channels);
    EXPECT_EQ(kept_pixels(*image_, warp::carve(m, k), false).pixels, lqr.pixels);
  }
  lqr_vmap_destroy(vmap);
}

TEST_F(SeamMaps, WhatAWidthKeepsEveryWiderWidthKeeps) {
  for (const VisibilityMap* m : {&maps_->horizontal, &maps_->vertical}) {
    std::vector<std::vector<bool>> kept_before(m->lines, std::vector<bool>(m->length, true));
    for (int k = 0; k <= m->depth; ++k) {
      const CarveTable t = warp::carve(*m, k);
      ASSERT_EQ(t.kept, m->length - k);
      for (int l = 0; l < m->lines; ++l) {
        std::vector<bool> kept(m->length, false);
        for (int j = 0; j < t.kept; ++j) {
          if (j > 0) {
            ASSERT_LT(t.line(l)[j - 1], t.line(l)[j]) << "in order";
          }
          kept[t.line(l)[j]] = true;
        }
        for (int p = 0; p < m->length; ++p) ASSERT_TRUE(!kept[p] || kept_before[l][p]) << "k " << k << " line " << l;
        kept_before[l] = kept;
      }
    }
  }
  EXPECT_THROW(warp::carve(maps_->horizontal, maps_->horizontal.depth + 1), std::invalid_argument);
  EXPECT_THROW(warp::carve(maps_->horizontal, -1), std::invalid_argument);
}

// [Guo09 §4.1]: the saliency protects what matters. At half width, the share of the top decile
// of salient pixels removed, with and without the bias (figures printed for the calibration).
TEST(SeamBias, FewerSalientPixelsAreRemovedWithTheBias) {
  const tiles::Raster image = boats(256, 160);
  const warp::SignificanceMap saliency = significance_of(image);
  std::vector<float> sorted = saliency.values;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() * 9 / 10, sorted.end());
  const float decile = sorted[sorted.size() * 9 / 10];
  const auto removed_salient = [&](int factor) {
    const VisibilityMap m = warp::compute_visibility_maps(image, saliency, factor).horizontal;
    const int k = m.length / 2;
    int removed = 0, salient = 0;
    for (int y = 0; y < m.lines; ++y)
      for (int x = 0; x < m.length; ++x)
        if (saliency.at(x, y) >= decile) {
          ++salient;
          if (m.at(y, x) != 0 && m.at(y, x) <= k) ++removed;
        }
    return double(removed) / salient;
  };
  const double without = removed_salient(0);
  for (int factor : {100, 10000, 100000})
    std::printf("[ figures ] bias factor %d: %.1f%% of the top-decile salient pixels removed at half width\n", factor,
                100 * removed_salient(factor));
  const double with = removed_salient(warp::kSaliencyBiasFactor);
  std::printf("[ figures ] top-decile salient pixels removed at half width: %.1f%% without the bias, %.1f%% with "
              "factor %d\n", 100 * without, 100 * with, warp::kSaliencyBiasFactor);
  EXPECT_LT(with, 0.75 * without);
}

TEST(SeamDegenerate, ThinAndTinyImagesCarveWhatCanBeCarved) {
  struct Case {
    int w, h;
  };
  for (Case s : {Case{1, 1}, Case{2, 2}, Case{1, 1024}, Case{2, 1024}, Case{1024, 1}, Case{1024, 2}, Case{16, 16},
                 Case{3, 700}}) {
    SCOPED_TRACE(std::to_string(s.w) + "x" + std::to_string(s.h));
    const tiles::Raster image = testing::test_pattern(s.w, s.h, 3);
    warp::SignificanceMap flat;
    flat.width = s.w, flat.height = s.h, flat.values.assign(std::size_t(s.w) * s.h, 0.5f);
    const VisibilityMaps maps = warp::compute_visibility_maps(image, flat);
    EXPECT_EQ(warp::check_visibility_map(maps.horizontal), "");
    EXPECT_EQ(warp::check_visibility_map(maps.vertical), "");
    // A side of one pixel has nothing to carve; an image one line thick is not carved across it
    // either (liblqr crashes on it).
    EXPECT_EQ(maps.horizontal.depth, s.h > 1 ? s.w * 9 / 10 : 0);
    EXPECT_EQ(maps.vertical.depth, s.w > 1 ? s.h * 9 / 10 : 0);
  }
}

TEST(SeamFile, BytesRoundTripAndDamageIsRefused) {
  const tiles::Raster image = boats(64, 40);
  const VisibilityMaps maps = warp::compute_visibility_maps(image, significance_of(image));
  const std::string bytes = warp::visibility_map_bytes(maps);
  const VisibilityMaps back = warp::parse_visibility_maps(bytes);
  EXPECT_EQ(back.horizontal.order, maps.horizontal.order);
  EXPECT_EQ(back.vertical.order, maps.vertical.order);
  EXPECT_THROW(warp::parse_visibility_maps(bytes.substr(0, bytes.size() - 1)), std::runtime_error);
  EXPECT_THROW(warp::parse_visibility_maps(bytes + "x"), std::runtime_error);
  // Seam 2 renamed 1 on the first line: seam 1 crosses it twice, seam 2 not at all.
  std::string twice = bytes;
  const auto& first = maps.horizontal.order;
  const std::size_t at2 = std::find(first.begin(), first.begin() + 64, 2) - first.begin();
  ASSERT_LT(at2, 64u);
  twice[12 + 2 * at2] = 1, twice[12 + 2 * at2 + 1] = 0;
  EXPECT_THROW(warp::parse_visibility_maps(twice), std::runtime_error);
  std::string deeper = bytes;
  deeper[8] = char(64);  // depth 64 on a 64 px side
  EXPECT_THROW(warp::parse_visibility_maps(deeper), std::runtime_error);
}

// Seams are carved at a long side of at most kSeamMaxSide (seam_resolution.h): the maps of a
// larger analysis image are made from it reduced, keep the format, carve to the screen's aspect
// and back, and the loader takes maps of the reduced size or of the analysis size itself (files
// written before) but no other.
TEST(SeamResolution, LargeAnalysisImagesAreCarvedReduced) {
  EXPECT_EQ(warp::seam_map_size(1024, 640).width, 512);
  EXPECT_EQ(warp::seam_map_size(1024, 640).height, 320);
  EXPECT_EQ(warp::seam_map_size(681, 1024).width, 341);
  EXPECT_EQ(warp::seam_map_size(512, 300).width, 512) << "small enough: as it is";
  EXPECT_EQ(warp::seam_map_size(1024, 1).height, 1);

  const tiles::Raster image = boats(640, 400);
  const warp::SignificanceMap saliency = significance_of(image);
  const VisibilityMaps reduced = warp::compute_seam_maps(image, saliency);
  expect_map_format(reduced.horizontal, 512, 320);
  expect_map_format(reduced.vertical, 320, 512);

  warp::SeamCarving engine(1280, 800, reduced);
  const warp::CarvedImage square = engine.carved(400, 400);
  EXPECT_DOUBLE_EQ(square.width, 800);
  EXPECT_EQ(square.seams, 192);  // 512 − 320 reduced columns
  const warp::CarvedImage wide = engine.carved(640, 200);
  ASSERT_TRUE(wide.vertical);
  EXPECT_EQ(wide.seams, 160);
  for (double x = 5; x < 1280; x += 97)
    for (double y = 3; y < wide.height; y += 41) {
      const warp::Point back = wide.from_source(wide.to_source({x, y}));
      EXPECT_NEAR(back.x, x, 1e-9);
      EXPECT_NEAR(back.y, y, 1e-6);
    }

  warp::ImageModel model;
  model.width = 1280, model.height = 800, model.significance = saliency;
  const warp::RetargetingMethod& seam = warp::seam_carving_method();
  EXPECT_NO_THROW(seam.load(model, saliency, warp::visibility_map_bytes(reduced)));
  EXPECT_NO_THROW(seam.load(model, saliency, warp::visibility_map_bytes(warp::compute_visibility_maps(image, saliency))))
      << "a file from before the reduction";
  const tiles::Raster smaller = boats(320, 200);
  EXPECT_THROW(seam.load(model, saliency,
                         warp::visibility_map_bytes(warp::compute_visibility_maps(smaller, significance_of(smaller)))),
               std::runtime_error);
  EXPECT_EQ(seam.precompute(warp::MethodInput{model, warp::Saliency::kDefault, saliency, image, {}, {}}),
            warp::visibility_map_bytes(reduced))
      << "the precomputation is the reduced maps";
}

TEST(SeamRegistry, SeamIsRegisteredWithoutAMesh) {
  const warp::RetargetingMethod* seam = warp::find_retargeting_method("seam");
  ASSERT_NE(seam, nullptr);
  EXPECT_FALSE(seam->has_mesh);
  EXPECT_TRUE(seam->precompute);
}

class SeamGeometry : public ::testing::Test {
 protected:
  // A 1600×1000 image whose analysis copy is 160×100.
  static void SetUpTestSuite() {
    const tiles::Raster image = boats(160, 100);
    engine_ = new warp::SeamCarving(1600, 1000, warp::compute_visibility_maps(image, significance_of(image)));
  }
  static void TearDownTestSuite() { delete engine_; }
  static warp::SeamCarving* engine_;
};
warp::SeamCarving* SeamGeometry::engine_ = nullptr;

TEST_F(SeamGeometry, EqualAspectIsTheIdentity) {
  const warp::CarvedImage c = engine_->carved(480, 300);
  EXPECT_EQ(c.width, 1600);
  EXPECT_EQ(c.height, 1000);
  EXPECT_EQ(c.seams, 0);
  for (double x : {0.0, 0.5, 12.25, 800.0, 1599.5})
    for (double y : {0.0, 333.3, 999.5}) {
      const warp::Point s = c.to_source({x, y}), back = c.from_source({x, y});
      EXPECT_NEAR(s.x, x, 1e-9);
      EXPECT_NEAR(s.y, y, 1e-9);
      EXPECT_NEAR(back.x, x, 1e-9);
    }
}

TEST_F(SeamGeometry, TheLongSideShrinksToTheScreensAspect) {
  const warp::CarvedImage square = engine_->carved(400, 400);
  EXPECT_FALSE(square.vertical);
  EXPECT_DOUBLE_EQ(square.width, 1000);
  EXPECT_DOUBLE_EQ(square.height, 1000);
  EXPECT_EQ(square.seams, 60);  // 160 − 100 analysis columns
  const warp::CarvedImage wide = engine_->carved(640, 200);
  EXPECT_TRUE(wide.vertical);
  EXPECT_DOUBLE_EQ(wide.width, 1600);
  EXPECT_DOUBLE_EQ(wide.height, 500);
  EXPECT_EQ(wide.seams, 50);
  // 1:20 is beyond the recorded seams (a tenth of the side): carved to the floor, then scaled.
  const warp::CarvedImage thin = engine_->carved(50, 1000);
  EXPECT_DOUBLE_EQ(thin.width, 50);
  EXPECT_EQ(thin.seams, 144);
  EXPECT_EQ(thin.table->kept, 16);
  EXPECT_NEAR(thin.to_source({50, 500}).x, (thin.table->line(50)[15] + 1) * 10, 1e-9);
}

TEST_F(SeamGeometry, KeptPointsGoThereAndBack) {
  const warp::CarvedImage c = engine_->carved(640, 200);
  ASSERT_TRUE(c.vertical);
  int checked = 0;
  for (double x = 5; x < 1600; x += 97)
    for (double y = 3; y < c.height; y += 41) {
      const warp::Point s = c.to_source({x, y});
      const warp::Point back = c.from_source(s);
      EXPECT_NEAR(back.x, x, 1e-9);
      EXPECT_NEAR(back.y, y, 1e-6);
      ++checked;
    }
  EXPECT_GT(checked, 150);
  EXPECT_THROW(engine_->view({}), warp::NoMesh);
}

// What each screen pixel shows (the metrics' input) is the carving seen through the zoom: at
// equal aspect and zoom 1 the plain crop, pixel centre for pixel centre; on a square screen at
// zoom 0 every pixel shows a point of the image (no letterbox), each the carved point under it.
TEST_F(SeamGeometry, ScreenSourcesAreTheCarvingThroughTheZoom) {
  warp::ViewRequest r;
  r.screen_width = 48, r.screen_height = 30, r.zoom = 1, r.cx = 800, r.cy = 500;
  std::vector<warp::Point> s = engine_->screen_sources(r);
  ASSERT_EQ(s.size(), 48u * 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 48; ++x) {
      EXPECT_NEAR(s[std::size_t(y) * 48 + x].x, 800 - 24 + x + 0.5, 1e-9);
      EXPECT_NEAR(s[std::size_t(y) * 48 + x].y, 500 - 15 + y + 0.5, 1e-9);
    }
  r.screen_width = r.screen_height = 40, r.zoom = 0;
  s = engine_->screen_sources(r);
  const warp::CarvedImage c = engine_->carved(40, 40);
  const double scale = 40 / c.width;
  for (int y = 0; y < 40; y += 7)
    for (int x = 0; x < 40; x += 5) {
      const warp::Point expected = c.to_source({(x + 0.5) / scale, (y + 0.5) / scale});
      EXPECT_NEAR(s[std::size_t(y) * 40 + x].x, expected.x, 1e-9);
      EXPECT_NEAR(s[std::size_t(y) * 40 + x].y, expected.y, 1e-9);
    }
}

}  // namespace
}  // namespace zoomwarp
