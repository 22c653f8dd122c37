// Private images through the router (no network): who may read them, what the image list shows,
// Cache-Control, and that the shared response cache never answers around the check. Keys come
// from a test double of api::Authenticator; the real key ring has its own tests.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "api/router.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"

namespace zoomwarp {
namespace {

using api::Authenticator;
using nlohmann::json;

// "Bearer curator" is a curator's key, "Bearer reader" a reader's; anything else is invalid.
class FakeKeys : public Authenticator {
 public:
  Result authenticate(std::string_view authorization) const override {
    if (authorization.empty()) return {};
    if (authorization == "Bearer curator") return {Outcome::kValid, {"cur-1", api::Role::kCurator}};
    if (authorization == "Bearer reader") return {Outcome::kValid, {"read-1", api::Role::kReader}};
    return {Outcome::kInvalid, {}};
  }
  bool has_keys() const override { return true; }
};

class PrivateImages : public ::testing::Test {
 protected:
  testing::TempDir dir;
  FakeKeys keys;
  tiles::Store store{dir.path() + "/store"};
  tiles::PyramidReader reader{16u << 20};
  api::Router router{store, reader, config()};

  api::RouterConfig config() const {
    api::RouterConfig c;
    c.access.keys = &keys;
    c.url_signer = std::make_shared<api::UrlSigner>(std::string(32, 's'));
    return c;
  }

  void SetUp() override {
    tiles::IngestOptions options;
    tiles::ingest_image(store, testing::samples_dir() + "/boats_lake_sunset.jpg", "open", options);
    options.is_private = true;
    tiles::ingest_image(store, testing::samples_dir() + "/boats_lake_sunset.jpg", "secret", options);
  }

  api::Response get(const std::string& target, const std::string& authorization = "") {
    api::Request req;
    req.method = "GET";
    const auto q = target.find('?');
    req.path = target.substr(0, q);
    req.query = q == std::string::npos ? "" : target.substr(q + 1);
    req.authorization = authorization;
    return router.handle(req);
  }

  std::string header(const api::Response& r, const std::string& name) {
    for (const auto& [k, v] : r.headers)
      if (k == name) return v;
    return "";
  }

  std::vector<std::string> listed(const std::string& authorization) {
    std::vector<std::string> ids;
    const api::Response r = get("/v1/images", authorization);
    EXPECT_EQ(r.status, 200) << *r.body;
    const json body = json::parse(*r.body);  // named: a range-for over a temporary's member dangles
    for (const auto& image : body["images"]) ids.push_back(image["id"]);
    return ids;
  }
};

TEST_F(PrivateImages, OnlyCuratorKeysSeeThemListed) {
  EXPECT_EQ(listed(""), std::vector<std::string>{"open"});
  EXPECT_EQ(listed("Bearer reader"), std::vector<std::string>{"open"});
  EXPECT_EQ(listed("Bearer wrong"), std::vector<std::string>{"open"});
  EXPECT_EQ(listed("Bearer curator"), (std::vector<std::string>{"open", "secret"}));
  EXPECT_EQ(header(get("/v1/images", "Bearer curator"), "Cache-Control"), "private, no-cache");
}

TEST_F(PrivateImages, ReadableWithACuratorKeyAsPrivateAnswers) {
  for (const std::string target : {"/v1/images/secret", "/dzi/secret.dzi", "/dzi/secret_files/8/0_0.jpg",
                                   "/iiif/3/secret/info.json", "/iiif/3/secret/full/64,/0/default.jpg"}) {
    SCOPED_TRACE(target);
    EXPECT_EQ(get(target).status, 404);
    EXPECT_EQ(get(target, "Bearer reader").status, 404) << "a reader's key is not enough";
    const api::Response r = get(target, "Bearer curator");
    EXPECT_EQ(r.status, 200);
    EXPECT_EQ(header(r, "Cache-Control").rfind("private", 0), 0u) << header(r, "Cache-Control");
    EXPECT_EQ(get(target.substr(0, target.find("secret")) + "open" + target.substr(target.find("secret") + 6))
                  .status, 200);
  }
  EXPECT_EQ(json::parse(*get("/v1/images/secret", "Bearer curator").body)["private"], true);
}

// The cache key of an answer does not name its reader: the check must come before the lookup, on
// the I/O thread's path (try_answer_now) as on the worker's (handle).
TEST_F(PrivateImages, TheSharedCacheDoesNotLeakThem) {
  const std::string tile = "/dzi/secret_files/9/0_0.jpg";
  ASSERT_EQ(get(tile, "Bearer curator").status, 200);
  const api::Response cached = get(tile, "Bearer curator");
  ASSERT_EQ(cached.cache, "hit");
  EXPECT_EQ(get(tile).status, 404);
  api::Request req;
  req.method = "GET";
  req.path = tile;
  const auto now = router.try_answer_now(req);
  ASSERT_TRUE(now);
  EXPECT_EQ(now->status, 404);
  req.if_none_match = header(cached, "ETag");
  EXPECT_EQ(router.try_answer_now(req)->status, 404) << "nor does a 304 confirm it";
}

TEST_F(PrivateImages, SignedUrlsOpenThemUntilTheyExpire) {
  const api::UrlSigner signer(std::string(32, 's'));
  const std::int64_t now = std::chrono::duration_cast<std::chrono::seconds>(
                               std::chrono::system_clock::now().time_since_epoch()).count();
  EXPECT_EQ(get(signer.sign("/iiif/3/secret/info.json", "", now + 600)).status, 200);
  const api::Response expired = get(signer.sign("/iiif/3/secret/info.json", "", now - 1));
  EXPECT_EQ(expired.status, 403);
  EXPECT_EQ(json::parse(*expired.body)["error"]["code"], "url_expired");
  const std::string signed_open = signer.sign("/iiif/3/open/info.json", "", now + 600);
  const api::Response moved = get("/iiif/3/secret/info.json" + signed_open.substr(signed_open.find('?')));
  EXPECT_EQ(moved.status, 403);
  EXPECT_EQ(json::parse(*moved.body)["error"]["code"], "bad_signature");
}

}  // namespace
}  // namespace zoomwarp
