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

  // Reads are open to every origin, also with a key (Authorization) and a validator.
  auto pre = http.request("OPTIONS", "/dzi/img.dzi", "", {{"Origin", "http://example.org"},
                                                           {"Access-Control-Request-Method", "GET"},
                                                           {"Access-Control-Request-Headers", "authorization"}});
  EXPECT_EQ(pre.status, 204);
  EXPECT_EQ(pre.header("access-control-allow-origin"), "*");
  EXPECT_NE(pre.header("access-control-allow-headers").find("Authorization"), std::string::npos);
  // Errors carry CORS headers too, so browsers can read them.
  EXPECT_EQ(http.get("/v1/images/nope").header("access-control-allow-origin"), "*");
}

// Writes only from --cors-write-origins: that exact origin in the answer, never "*", never
// credentials (keys travel in Authorization, which is not credentials mode; server/cors.h).
class CorsWrites : public ::testing::Test {
 protected:
  testing::TempDir dir;
  testing::ServerProcess server{dir.path() + "/store", {"--cors-write-origins", "https://curate.example.org, http://localhost:3000"}};
  HttpClient http{server.port()};

  testing::HttpResponse preflight(const std::string& origin, const std::string& method) {
    return http.request("OPTIONS", "/v1/images/img/lines", "",
                        {{"Origin", origin}, {"Access-Control-Request-Method", method},
                         {"Access-Control-Request-Headers", "authorization,content-type,if-match"}});
  }
};

TEST_F(CorsWrites, AnAllowedOriginMayWrite) {
  for (const std::string origin : {"https://curate.example.org", "http://localhost:3000"}) {
    SCOPED_TRACE(origin);
    const auto pre = preflight(origin, "PUT");
    EXPECT_EQ(pre.status, 204);
    EXPECT_EQ(pre.header("access-control-allow-origin"), origin);
    EXPECT_EQ(pre.header("vary"), "Origin");
    EXPECT_EQ(pre.header("access-control-allow-methods"), "POST, PUT, PATCH, DELETE");
    EXPECT_EQ(pre.header("access-control-allow-headers"), "Authorization, Content-Type, If-Match");
    EXPECT_EQ(pre.header("access-control-allow-credentials"), "");
    const auto write = http.request("DELETE", "/v1/images/nope", "", {{"Origin", origin}});
    EXPECT_EQ(write.header("access-control-allow-origin"), origin) << "the write's answer is readable there";
    EXPECT_EQ(write.header("vary"), "Origin");
  }
}

TEST_F(CorsWrites, OtherOriginsGetNoAllowHeadersForWrites) {
  for (const std::string origin : {"https://evil.example.org", "https://curate.example.org.evil.net", "null"}) {
    SCOPED_TRACE(origin);
    const auto pre = preflight(origin, "DELETE");
    EXPECT_EQ(pre.status, 204);
    EXPECT_EQ(pre.header("access-control-allow-origin"), "");
    EXPECT_EQ(pre.header("access-control-allow-methods"), "");
    const auto write = http.request("DELETE", "/v1/images/nope", "", {{"Origin", origin}});
    EXPECT_EQ(write.header("access-control-allow-origin"), "");
    EXPECT_EQ(http.get("/v1/images", {{"Origin", origin}}).header("access-control-allow-origin"), "*")
        << "reads stay open";
  }
}

}  // namespace
}  // namespace zoomwarp
