// GET /v1/methods on the wire: the methods a view request may name, as the viewer's menus list
// them — api's own first, then every registered retargeting method, exactly the OpenAPI
// document's method= values — each one answering /viewport, and /mesh unless it says it has none;
// the saliency kinds; public, cacheable, 304 on its ETag.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/json_schema.h"
#include "tests/support/server_process.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;

class Methods : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    server_ = new testing::ServerProcess(dir_->path() + "/store");
    HttpClient http(server_->port());
    const auto r = http.request("POST", "/v1/images?id=astronaut",
                                testing::read_file(testing::samples_dir() + "/astronaut_portrait.png"));
    ASSERT_EQ(r.status, 201) << r.body;
  }
  static void TearDownTestSuite() {
    delete server_;
    delete dir_;
  }

  json methods() {
    const auto r = http.get("/v1/methods");
    EXPECT_EQ(r.status, 200) << r.body;
    return r.status == 200 ? json::parse(r.body) : json();
  }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
};
testing::TempDir* Methods::dir_ = nullptr;
testing::ServerProcess* Methods::server_ = nullptr;

TEST_F(Methods, ListsApisOwnThenEveryRegisteredMethodAndTheSaliencyKinds) {
  const auto r = http.get("/v1/methods");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.header("content-type"), "application/json");
  const json body = json::parse(r.body);
  const json openapi = json::parse(http.get("/openapi.json").body);
  EXPECT_EQ(testing::validate_json(body, openapi["components"]["schemas"]["MethodList"], openapi),
            std::vector<std::string>{});

  std::vector<std::string> names;
  for (const json& m : body["methods"]) {
    names.push_back(m["name"]);
    EXPECT_FALSE(m["summary"].get<std::string>().empty()) << m;
    EXPECT_FALSE(m["zoom"].get<std::string>().empty()) << m;
  }
  // ICAZ first (the default), then traditional zoom, Retarget+Zoom and the retargeting methods;
  // each name once, and exactly the names the served OpenAPI document offers for method=.
  ASSERT_GE(names.size(), 3u);
  EXPECT_EQ(names[0], "icaz");
  EXPECT_EQ(names[1], "traditional");
  for (const char* name : {"retarget-zoom", "seam", "mp", "patch", "polyfem"})
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
  const std::set<std::string> listed(names.begin(), names.end());
  EXPECT_EQ(listed.size(), names.size()) << body;
  const json& offered = openapi["components"]["parameters"]["method"]["schema"]["enum"];
  EXPECT_EQ(std::set<std::string>(offered.begin(), offered.end()), listed);
  // Every registered method, in the registry's order, as it describes itself.
  auto at = names.begin();
  for (const warp::RetargetingMethod* m : warp::retargeting_methods()) {
    at = std::find(at, names.end(), m->name);
    ASSERT_NE(at, names.end()) << m->name << " is registered but not listed, or listed out of order";
    const json& listed = body["methods"][std::size_t(at - names.begin())];
    EXPECT_EQ(listed["mesh"], m->has_mesh) << m->name;
    EXPECT_EQ(listed["summary"], m->summary) << m->name;
    EXPECT_EQ(listed["zoom"], m->zoom) << m->name;
  }
  EXPECT_EQ(body["saliency"], json::parse(R"(["default", "gbvs"])"));

  // The index links it.
  EXPECT_EQ(json::parse(http.get("/v1").body)["links"]["methods"], "/v1/methods");
}

// What the list says of each method is what the view routes do: every listed name is a method
// /viewport takes, and /mesh serves exactly those with `mesh: true` (the others: 501 with a JSON
// error naming /viewport). A name not listed is a 400 whose message lists them all.
TEST_F(Methods, EveryListedMethodAnswersAsItsEntrySays) {
  const json listed = methods()["methods"];
  ASSERT_GE(listed.size(), 3u);
  std::string all;
  for (const json& m : listed) {
    const std::string name = m["name"];
    all += (all.empty() ? "" : ", ") + name;
    const std::string view = "zoom=0.3&cx=256&cy=200&w=96&h=64&method=" + name;
    const auto viewport = http.get("/v1/images/astronaut/viewport?" + view);
    EXPECT_EQ(viewport.status, 200) << name << ": " << viewport.body;
    EXPECT_EQ(viewport.header("content-type"), "image/jpeg") << name;
    const auto mesh = http.get("/v1/images/astronaut/mesh?" + view);
    if (m["mesh"]) {
      EXPECT_EQ(mesh.status, 200) << name << ": " << mesh.body;
      if (mesh.status == 200) {
        EXPECT_EQ(json::parse(mesh.body)["view"]["method"], name);
      }
    } else {
      EXPECT_EQ(mesh.status, 501) << name << ": " << mesh.body;
      EXPECT_EQ(json::parse(mesh.body)["error"]["code"], "not_implemented") << name;
    }
  }
  const auto unknown = http.get("/v1/images/astronaut/viewport?w=96&h=64&method=no-such-method");
  ASSERT_EQ(unknown.status, 400) << unknown.body;
  const std::string message = json::parse(unknown.body)["error"]["message"];
  EXPECT_NE(message.find(all), std::string::npos) << message << " should list " << all;
}

// The list changes only with the server's build: public, cached for max-age, and revalidated with
// a strong ETag (304 to If-None-Match, weak comparison), with or without a key.
TEST_F(Methods, IsPublicAndRevalidatesWithItsETag) {
  const auto first = http.get("/v1/methods");
  ASSERT_EQ(first.status, 200);
  const std::string etag = first.header("etag");
  ASSERT_FALSE(etag.empty());
  EXPECT_EQ(etag.front(), '"') << "a strong ETag";
  EXPECT_EQ(first.header("cache-control").rfind("public, max-age=", 0), 0u) << first.header("cache-control");
  EXPECT_EQ(http.get("/v1/methods").header("etag"), etag) << "the same body, the same tag";

  const auto revalidated = http.request("GET", "/v1/methods", "", {{"If-None-Match", "W/" + etag}});
  EXPECT_EQ(revalidated.status, 304);
  EXPECT_EQ(revalidated.header("etag"), etag);
  EXPECT_TRUE(revalidated.body.empty());
  EXPECT_EQ(http.request("GET", "/v1/methods", "", {{"If-None-Match", "\"something-else\""}}).status, 200);
  EXPECT_EQ(http.request("POST", "/v1/methods", "{}").status, 405);
}

}  // namespace
}  // namespace zoomwarp
