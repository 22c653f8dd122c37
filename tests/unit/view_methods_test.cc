// api/view_methods.h and api::WarpEngines::view_engine: every method a view may name is one
// entry of one table, and the Retargeter a route draws it through gives the views the method's
// own engine gives — ICAZ's warp per view and its geomorph (the common refinement of two LOD
// cuts), traditional zoom on the default map whatever `saliency=` says, each registered method's
// own — so that /viewport and /mesh, which only ever ask view_engine, show each method as it is.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "api/view_methods.h"
#include "tests/support/ingested_image.h"

namespace zoomwarp {
namespace {

// One ingested sample and its engines, shared by the tests (a model is built once).
testing::IngestedImage& sample() {
  static testing::IngestedImage s(testing::samples_dir() + "/boats_lake_sunset.jpg", "boats");
  return s;
}

warp::ViewRequest request(double zoom, double cx, double cy, int w = 480, int h = 360) {
  warp::ViewRequest r;
  r.zoom = zoom, r.cx = cx, r.cy = cy, r.screen_width = w, r.screen_height = h;
  return r;
}

void expect_same_points(const std::vector<warp::Point>& a, const std::vector<warp::Point>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].x, b[i].x) << "vertex " << i;
    EXPECT_EQ(a[i].y, b[i].y) << "vertex " << i;
  }
}

TEST(ViewMethods, OneTableInTheViewersOrder) {
  std::vector<std::string> expected = {"icaz", "traditional"};
  for (const warp::RetargetingMethod* m : warp::retargeting_methods()) expected.emplace_back(m->name);
  std::vector<std::string> names;
  for (const api::ViewMethod& m : api::view_methods()) {
    names.emplace_back(m.name());
    EXPECT_EQ(api::find_view_method(m.name()), &m);
    EXPECT_EQ(m.registered == nullptr, m.name() == "icaz" || m.name() == "traditional") << m.name();
  }
  EXPECT_EQ(names, expected);
  EXPECT_EQ(api::default_view_method().name(), "icaz");
  EXPECT_EQ(api::find_view_method("bogus"), nullptr);
  const api::ViewMethod& traditional = *api::find_view_method("traditional");
  EXPECT_FALSE(traditional.takes_lines());
  EXPECT_FALSE(traditional.reads_saliency);
  EXPECT_TRUE(api::find_view_method("icaz")->takes_lines());
}

TEST(ViewEngines, IcazIsDrawnAsTheOperatorDrawsItWithItsOwnGeomorph) {
  auto& s = sample();
  const auto& e = *s.entry;
  const auto engine = s.engines.view_engine(e, *api::find_view_method("icaz"), warp::Saliency::kDefault, warp::LineSet::kAuto);
  const auto icaz = s.engines.get(e, warp::Saliency::kDefault, warp::LineSet::kAuto);
  const warp::ViewRequest from = request(0, e.manifest.width / 2.0, e.manifest.height / 2.0);
  const warp::ViewRequest to = request(0.5, e.manifest.width * 0.3, e.manifest.height * 0.6);
  expect_same_points(engine->view(to).screen, icaz->view(to).screen);
  warp::View drawn, own;
  const warp::Geomorph pair = engine->geomorph(from, to, &drawn);
  const warp::Geomorph expected = icaz->geomorph(from, to, &own);
  expect_same_points(pair.from, expected.from);
  expect_same_points(pair.to, expected.to);
  expect_same_points(drawn.screen, own.screen);
}

TEST(ViewEngines, TraditionalZoomReadsNoMapAndPairsOneMeshVertexByVertex) {
  auto& s = sample();
  const auto& e = *s.entry;
  const api::ViewMethod& traditional = *api::find_view_method("traditional");
  const auto plain = s.engines.get(e, warp::Saliency::kDefault, warp::LineSet::kCurator);
  const warp::ViewRequest from = request(0.2, e.manifest.width / 2.0, e.manifest.height / 2.0);
  const warp::ViewRequest to = request(0.7, e.manifest.width * 0.4, e.manifest.height * 0.5);
  for (const warp::Saliency saliency : warp::kSaliencies) {
    const auto engine = s.engines.view_engine(e, traditional, saliency, warp::LineSet::kCurator);
    const warp::View view = engine->view(to);
    EXPECT_TRUE(view.uniform);
    expect_same_points(view.screen, plain->traditional(to).screen);
    warp::View drawn;
    const warp::Geomorph pair = engine->geomorph(from, to, &drawn);
    expect_same_points(pair.from, plain->traditional(from).screen);
    expect_same_points(pair.to, drawn.screen);
    expect_same_points(pair.to, view.screen);
  }
}

TEST(ViewEngines, RegisteredMethodsAreTheirOwnEngines) {
  auto& s = sample();
  const auto& e = *s.entry;
  for (const api::ViewMethod& m : api::view_methods()) {
    if (!m.registered || !m.description.has_mesh) continue;
    const warp::ViewRequest r = request(0.3, e.manifest.width / 2.0, e.manifest.height / 2.0, 360, 640);
    const auto drawn = s.engines.view_engine(e, m, warp::Saliency::kDefault, warp::LineSet::kAuto, nullptr, 360, 640);
    const auto own = s.engines.retargeter(e, *m.registered, warp::Saliency::kDefault, warp::LineSet::kAuto);
    EXPECT_EQ(drawn.get(), own.get()) << m.name();  // the engine kept for the version, not a copy
    expect_same_points(drawn->view(r).screen, own->view(r).screen);
  }
}

}  // namespace
}  // namespace zoomwarp
