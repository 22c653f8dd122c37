// Issue 30's acceptance on the bundled photographs, for every mesh method as /mesh serves it: at
// zoom 0, view centred, default parameters, on a phone's portrait and landscape screens, the
// salient region turns by at most 10° (rotation p95, warp/compare/metrics.h) and every line the
// server detected (and the curator drew) that is at least 8 screen px long stays within 2 px of
// straight. The control: with the curator's lines only (the default before issue 30) ICAZ bends
// the boats' horizon and gunwales past the bound, so the measure sees what the default fixed.
// planks_by_the_water.jpg, a 1 MP photograph (analysed at 640×400), is where mp's object scale z
// could not be reached on a 9:16 screen: without mp_solve's step 6 the planks' lines bent 5.9 px
// around triangles squeezed to 1e-11 of their area. The boats at 1280 px: the same photograph made
// 1280 px wide by vips (EveningGlow in tests/bench/unseen_photos.sh) leaned 10.05° under ICAZ
// before its rotation term (Icaz::kRotationWeight); this copy, OpenImageIO's resize, 9.5° then
// and 6.8° now.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "tests/support/images.h"
#include "tests/support/ingested_image.h"
#include "tests/support/server_process.h"
#include "warp/analysis/detected_lines.h"
#include "warp/analysis/saliency_files.h"
#include "warp/compare/metrics.h"

namespace zoomwarp {
namespace {

constexpr double kMaxRotationDegrees = 10;
constexpr double kMaxBendPx = 2;

struct Screen {
  int w, h;
};
constexpr Screen kScreens[] = {{360, 640}, {640, 360}};
constexpr const char* kMeshMethods[] = {"icaz", "retarget-zoom", "mp", "patch", "polyfem"};

// One sample ingested, with what the metrics measure against: the default significance map, the
// lines that must stay straight, and traditional zoom.
class StraightLines : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override {
    image_ = std::make_unique<testing::IngestedImage>(sample_path(GetParam()), "sample");
    const tiles::ImageEntry& e = *image_->entry;
    const warp::ImageModel& stored =
        image_->engines.get(e, warp::Saliency::kDefault, warp::LineSet::kCurator)->model();
    map_ = warp::saliency_map(e, image_->reader, stored, warp::Saliency::kDefault);
    lines_ = stored.lines;
    for (const warp::Segment& s : warp::suggested_lines(e, image_->reader, stored)) lines_.push_back(s);
  }

  warp::ViewMetrics measure(const std::string& method, Screen s, const std::string& extra = "") {
    const std::string query = "zoom=0&w=" + std::to_string(s.w) + "&h=" + std::to_string(s.h) + "&method=" + method + extra;
    const auto views = image_->mesh_views(query);
    const warp::View traditional = image_->engines.get(*image_->entry)->traditional(views.query.view);
    return warp::mesh_view_metrics(views.view, traditional, map_, lines_, s.w, s.h);
  }

  // "file" is samples/file; "file@W" a copy made W px wide here (a 1 MP photograph, analysed
  // at a pyramid level of 640 px where the full size is analysed at 1024).
  std::string sample_path(const std::string& name) {
    const std::size_t at = name.find('@');
    if (at == std::string::npos) return testing::samples_dir() + "/" + name;
    const tiles::Raster full = testing::load_image(testing::samples_dir() + "/" + name.substr(0, at));
    const int w = std::stoi(name.substr(at + 1));
    const std::string path = copies_.path() + "/" + name.substr(0, at);
    testing::write_image(path, testing::resize(full, w, int(std::lround(double(full.height) * w / full.width))), 8, 1, 90);
    return path;
  }

  testing::TempDir copies_;
  std::unique_ptr<testing::IngestedImage> image_;
  warp::SignificanceMap map_;
  std::vector<warp::Segment> lines_;
};

TEST_P(StraightLines, EveryMeshMethodKeepsShapesUprightAndLinesStraightOnPhoneScreens) {
  ASSERT_FALSE(lines_.empty()) << "a sample without detected lines tests nothing here";
  for (const char* method : kMeshMethods)
    for (const Screen s : kScreens) {
      SCOPED_TRACE(std::string(method) + " " + std::to_string(s.w) + "x" + std::to_string(s.h));
      const warp::ViewMetrics m = measure(method, s);
      ASSERT_TRUE(m.rotation_p95 && m.lines_measured);
      std::printf("%s %-13s %dx%d: rotation p95 %5.2f°, spread %5.2f°, %2d lines, worst bend %5.2f px, gain %.2f\n",
                  GetParam(), method, s.w, s.h, *m.rotation_p95, m.rotation_spread.value_or(0), *m.lines_measured,
                  m.straightness.value_or(0), m.scale_gain.value_or(0));
      EXPECT_LE(*m.rotation_p95, kMaxRotationDegrees);
      EXPECT_LE(m.straightness.value_or(0), kMaxBendPx);
      EXPECT_EQ(m.folds.value_or(-1), 0);
    }
}

INSTANTIATE_TEST_SUITE_P(Samples, StraightLines,
                         ::testing::Values("boats_lake_sunset.jpg", "interior_wine_djembe_tall.jpg",
                                           "pano_grossmugl_field_4to1.png", "astronaut_portrait.png",
                                           "planks_by_the_water.jpg", "boats_lake_sunset.jpg@1280"),
                         [](const auto& info) {
                           const std::string name = info.param;
                           const std::size_t at = name.find('@');
                           return name.substr(0, name.find('.')) + (at == std::string::npos ? "" : "_" + name.substr(at + 1));
                         });

// The control: the boats at 360×640 with the curator's lines only bend past the bound under ICAZ.
TEST(StraightLinesControl, WithoutTheDetectedLinesIcazBendsTheBoatsPastTheBound) {
  testing::IngestedImage image(testing::samples_dir() + "/boats_lake_sunset.jpg", "boats");
  const tiles::ImageEntry& e = *image.entry;
  const warp::ImageModel& stored = image.engines.get(e, warp::Saliency::kDefault, warp::LineSet::kCurator)->model();
  const warp::SignificanceMap map = warp::saliency_map(e, image.reader, stored, warp::Saliency::kDefault);
  const std::vector<warp::Segment> lines = warp::suggested_lines(e, image.reader, stored);
  const auto views = image.mesh_views("zoom=0&w=360&h=640&lines=curator");
  const warp::View traditional = image.engines.get(e)->traditional(views.query.view);
  const warp::ViewMetrics m = warp::mesh_view_metrics(views.view, traditional, map, lines, 360, 640);
  std::printf("icaz lines=curator: worst bend %.2f px over %d lines\n", m.straightness.value_or(0),
              m.lines_measured.value_or(0));
  EXPECT_GT(m.straightness.value_or(0), kMaxBendPx);
}

}  // namespace
}  // namespace zoomwarp
