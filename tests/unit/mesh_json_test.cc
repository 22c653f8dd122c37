// api::mesh_json, the /mesh body written as text, against the nlohmann tree it replaced
// (tests/support/mesh_json_reference.h): on real views of a sample — ICAZ, traditional and every
// registered method with a mesh, alone and as geomorph pairs — and on a view made of the numbers
// that are hard to print. "The same document" is checked strictly: the new text, parsed and
// dumped again by nlohmann, is the old text byte for byte (keys, their order, values, and whether
// a number is an integer or a real).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "api/mesh_json.h"
#include "tests/support/ingested_image.h"
#include "tests/support/mesh_json_reference.h"
#include "warp/core/uniform_zoom.h"

namespace zoomwarp {
namespace {

using nlohmann::json;

// One ingested sample and its engines, shared by the tests (a model is built once).
testing::IngestedImage& sample() {
  static testing::IngestedImage s(testing::samples_dir() + "/boats_lake_sunset.jpg", "boats");
  return s;
}

using MeshViews = testing::IngestedImage::MeshViews;

std::string written(const MeshViews& m, const tiles::Manifest& image) {
  return api::mesh_json(image, m.query, m.view, m.morph ? &*m.morph : nullptr, api::DziLayout{}, "jpg");
}

std::string reference(const MeshViews& m, const tiles::Manifest& image) {
  return testing::reference_mesh_json(image, m.query, m.view, m.morph ? &*m.morph : nullptr, api::DziLayout{}, "jpg");
}

void expect_same_document(const std::string& now, const std::string& before) {
  ASSERT_FALSE(now.empty());
  EXPECT_EQ(now.back(), '\n');
  EXPECT_EQ(json::parse(now).dump(), json::parse(before).dump());
}

class MeshJsonViews : public ::testing::TestWithParam<const char*> {};

TEST_P(MeshJsonViews, WritesTheDocumentTheTreeDid) {
  const MeshViews m = sample().mesh_views(GetParam());
  const tiles::Manifest& image = sample().entry->manifest;
  const std::string now = written(m, image);
  expect_same_document(now, reference(m, image));
  const json body = json::parse(now);
  EXPECT_GT(body["triangles"].size(), 0u);  // a view worth comparing
  EXPECT_GT(body["tiles"].size(), 0u);
  EXPECT_EQ(body.contains("from"), m.morph.has_value());
}

INSTANTIATE_TEST_SUITE_P(
    RealViews, MeshJsonViews,
    ::testing::Values("w=480&h=360", "w=480&h=360&zoom=0.5&cx=700&cy=500", "w=360&h=640&zoom=1&cx=2500&cy=1550",
                      "w=480&h=360&zoom=0.3&curve=linear", "w=480&h=360&zoom=0.6&cx=900&cy=800&saliency=gbvs",
                      "w=480&h=360&zoom=0.5&cx=1200&cy=800&from_zoom=0.3&from_cx=1000&from_cy=700",
                      "w=360&h=640&zoom=0.8&cx=300&cy=200&from_zoom=0.9&from_cx=500",
                      "w=480&h=360&zoom=0.4&method=traditional",
                      "w=480&h=360&zoom=0.4&method=traditional&from_zoom=0.2&from_cx=400",
                      "w=360&h=640&zoom=0.5&method=retarget-zoom",
                      "w=360&h=640&zoom=0.5&method=retarget-zoom&from_zoom=0.4", "w=360&h=640&zoom=0.5&method=mp",
                      "w=360&h=640&zoom=0.5&method=mp&from_zoom=0.6&from_cy=900", "w=360&h=640&zoom=0.5&method=patch",
                      "w=640&h=360&zoom=0.7&cx=2000&method=patch&from_zoom=0.5", "w=360&h=640&zoom=0.5&method=polyfem",
                      "w=360&h=640&zoom=0.2&method=polyfem&from_zoom=0"));

// The numbers that are hard to print, in a one-triangle view: negative zero, halves of a
// thousandth (rounded away from zero), whole numbers (written as reals), large and tiny values.
TEST(MeshJson, WritesHardNumbersAsTheTreeDid) {
  const tiles::Manifest& image = sample().entry->manifest;
  MeshViews m{api::parse_view_query("w=480&h=360&zoom=0.123456789&cx=1000.5&cy=7", api::ViewRoute::kMesh, image.width,
                                    image.height),
              {}, {}};
  m.view.source.vertices = {{0, 0}, {2559.9995, 0.0005}, {1e-4, 1599.99949}};
  m.view.source.triangles = {{0, 1, 2}};
  m.view.screen = {{-0.0004, -0.0005}, {479.0, 123456.7895}, {1e15 + 0.25, 3.0e-7}};
  m.view.visible = {0};
  m.view.geometry = {2560, 1600, 2560.0 / 3, 1e-3 / 7, 1.0 / 3};
  m.view.view_x = -12.3456, m.view.view_y = 1e9 / 7;
  m.view.centre_clamped = true;
  expect_same_document(written(m, image), reference(m, image));
  m.morph = warp::Geomorph{m.view.source, {}, {{0.0015, -2.0}, {-0.0, 7e-4}, {99999.9995, 0.1}}, m.view.screen};
  expect_same_document(written(m, image), reference(m, image));
}

// JSON has no NaN or infinity. The tree wrote null, which the OpenAPI schema does not allow and the
// web viewer would draw at 0; a warp that produced one is a bug: an error (a 500), not a body.
TEST(MeshJson, RefusesAPositionThatIsNotFinite) {
  const tiles::Manifest& image = sample().entry->manifest;
  MeshViews nan_screen = sample().mesh_views("w=480&h=360&zoom=0.5");
  ASSERT_FALSE(nan_screen.view.visible.empty());
  const int v = nan_screen.view.source.triangles[std::size_t(nan_screen.view.visible[0])][0];
  nan_screen.view.screen[std::size_t(v)].y = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(written(nan_screen, image), std::runtime_error);

  MeshViews inf_from = sample().mesh_views("w=480&h=360&zoom=0.5&from_zoom=0.4");
  ASSERT_TRUE(inf_from.morph);
  const auto drawn = warp::visible_triangles(inf_from.morph->source, inf_from.morph->to, 480, 360);
  ASSERT_FALSE(drawn.empty());
  const int w = inf_from.morph->source.triangles[std::size_t(drawn[0])][1];
  inf_from.morph->from[std::size_t(w)].x = std::numeric_limits<double>::infinity();
  EXPECT_THROW(written(inf_from, image), std::runtime_error);
}

}  // namespace
}  // namespace zoomwarp
