// HTTP caching and CORS: ETag, Last-Modified, Cache-Control, 304, HEAD, preflight, and that a
// re-published image changes every validator.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tests/support/http_client.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using testing::HttpClient;

class Caching : public ::testing::Test {
 protected:
  testing::TempDir dir;
  testing::ServerProcess server{dir.path() + "/store", {"--cache-max-age", "120"}};
  HttpClient http{server.port()};

  void SetUp() override {
    ASSERT_EQ(http.request("POST", "/v1/images?id=img", testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg")).status, 201);
  }
};

TEST_F(Caching, ValidatorsAnd304) {
  for (const std::string target : {"/dzi/img_files/10/1_1.jpg", "/iiif/3/img/full/200,/0/default.png",
                                   "/iiif/3/img/info.json", "/dzi/img.dzi"}) {
    SCOPED_TRACE(target);
    auto first = http.get(target);
    ASSERT_EQ(first.status, 200);
    const std::string etag = first.header("etag");
    ASSERT_FALSE(etag.empty());
    EXPECT_EQ(etag.front(), '"');
    EXPECT_FALSE(first.header("last-modified").empty());
    EXPECT_EQ(first.header("cache-control"), "public, max-age=120");
    EXPECT_EQ(first.header("access-control-allow-origin"), "*");

    auto again = http.get(target);
    EXPECT_EQ(again.header("etag"), etag);
    EXPECT_EQ(again.body, first.body);

    auto not_modified = http.get(target, {{"If-None-Match", etag}});
    EXPECT_EQ(not_modified.status, 304);
    EXPECT_TRUE(not_modified.body.empty());
    EXPECT_EQ(not_modified.header("etag"), etag);
    EXPECT_EQ(http.get(target, {{"If-None-Match", "\"other\", W/" + etag}}).status, 304);
    EXPECT_EQ(http.get(target, {{"If-None-Match", "*"}}).status, 304);
    EXPECT_EQ(http.get(target, {{"If-None-Match", "\"something-else\""}}).status, 200);
  }
  // Different requests have different tags.
  EXPECT_NE(http.get("/dzi/img_files/10/1_1.jpg").header("etag"), http.get("/dzi/img_files/10/1_2.jpg").header("etag"));
}

TEST_F(Caching, RepublishingChangesTheValidators) {
  const std::string target = "/iiif/3/img/full/100,/0/default.jpg";
  auto before = http.get(target);
  const std::string old_etag = before.header("etag");
  ASSERT_EQ(http.request("POST", "/v1/images?id=img",
                         testing::read_file(testing::samples_dir() + "/interior_wine_djembe_tall.jpg")).status, 201);
  auto after = http.get(target, {{"If-None-Match", old_etag}});
  EXPECT_EQ(after.status, 200) << "the old ETag no longer matches";
  EXPECT_NE(after.header("etag"), old_etag);
  EXPECT_NE(after.body, before.body) << "the cached response of the old version is not served";
}

TEST_F(Caching, HeadAndPreflight) {
  auto get = http.get("/dzi/img_files/11/0_0.jpg");
  auto head = http.request("HEAD", "/dzi/img_files/11/0_0.jpg");
  EXPECT_EQ(head.status, 200);
  EXPECT_TRUE(head.body.empty());
  EXPECT_EQ(head.header("content-length"), std::to_string(get.body.size()));
  EXPECT_EQ(head.header("etag"), get.header("etag"));

  auto pre = http.request("OPTIONS", "/v1/images", "", {{"Origin", "http://example.org"},
                                                         {"Access-Control-Request-Method", "POST"}});
  EXPECT_EQ(pre.status, 204);
  EXPECT_EQ(pre.header("access-control-allow-origin"), "*");
  EXPECT_NE(pre.header("access-control-allow-methods").find("POST"), std::string::npos);
  // Errors carry CORS headers too, so browsers can read them.
  EXPECT_EQ(http.get("/v1/images/nope").header("access-control-allow-origin"), "*");
}

}  // namespace
}  // namespace zoomwarp
