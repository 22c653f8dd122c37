// Private images over HTTP: every read route refuses them unsigned (404, as for an unknown image),
// opens them to a URL signed by `zoomwarp sign`, refuses expired and tampered URLs (403), keeps
// them out of the list and out of shared caches; edits keep them private, a re-upload says again.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "api/url_signing.h"
#include "tests/support/http_client.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;

constexpr const char* kSecretHex = "00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff";

std::string write_secret(const std::string& dir) {
  const std::string path = dir + "/signing.key";
  std::ofstream(path) << kSecretHex << "\n";
  return path;
}

// Every read route of an image, with parameters a view needs. (GET /iiif/3/{id} is a redirect.)
const std::vector<std::string> kReads = {
    "/v1/images/ID",
    "/v1/images/ID/viewport?zoom=0.5&w=64&h=48",
    "/v1/images/ID/mesh?zoom=0.5&w=64&h=48",
    "/v1/images/ID/significance.png",
    "/v1/images/ID/lines",
    "/dzi/ID.dzi",
    "/dzi/ID_files/8/0_0.jpg",
    "/iiif/3/ID",
    "/iiif/3/ID/info.json",
    "/iiif/3/ID/full/64,/0/default.jpg",
};

std::string with_id(std::string target, const std::string& id) { return target.replace(target.find("ID"), 2, id); }

class Private : public ::testing::Test {
 protected:
  testing::TempDir dir;
  const std::string key_file = write_secret(dir.path());
  testing::ServerProcess server{dir.path() + "/store", {"--signing-key", key_file}};
  HttpClient http{server.port()};

  void SetUp() override {
    const std::string jpg = testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg");
    ASSERT_EQ(http.request("POST", "/v1/images?id=secret&private=true", jpg).status, 201);
    ASSERT_EQ(http.request("POST", "/v1/images?id=other&private=1", jpg).status, 201);
    ASSERT_EQ(http.request("POST", "/v1/images?id=open", jpg).status, 201);
  }

  // What `zoomwarp sign` prints for `target` on this server, as a target again.
  std::string sign(const std::string& target, const std::string& expires = "1h") {
    const std::string origin = "http://127.0.0.1:" + std::to_string(server.port());
    const auto run = testing::run_command(
        {testing::zoomwarp_binary(), "sign", origin + target, "--expires", expires, "--signing-key", key_file});
    EXPECT_EQ(run.exit_code, 0) << run.output;
    std::string url = run.output.substr(0, run.output.find('\n'));
    EXPECT_EQ(url.rfind(origin, 0), 0u) << url;
    return url.substr(origin.size());
  }

  static std::string code(const testing::HttpResponse& r) {
    return json::parse(r.body, nullptr, false).value("error", json::object()).value("code", "");
  }
};

TEST_F(Private, UnsignedReadsAreNotFound) {
  for (const auto& route : kReads) {
    SCOPED_TRACE(route);
    const auto r = http.get(with_id(route, "secret"));
    EXPECT_EQ(r.status, 404);
    EXPECT_EQ(code(r), "image_not_found") << "the same answer as for an image that does not exist";
    EXPECT_EQ(r.body.find("private"), std::string::npos);
    EXPECT_EQ(http.get(with_id(route, "open")).status, route == "/iiif/3/ID" ? 303 : 200);
  }
}

TEST_F(Private, SignedUrlsOpenEveryReadRouteAsPrivateAnswers) {
  for (const auto& route : kReads) {
    SCOPED_TRACE(route);
    const auto r = http.get(sign(with_id(route, "secret")));
    EXPECT_EQ(r.status, route == "/iiif/3/ID" ? 303 : 200) << r.body;
    if (r.status != 200) continue;
    EXPECT_EQ(r.header("cache-control").rfind("private", 0), 0u) << r.header("cache-control");
    EXPECT_EQ(r.header("cache-control").find("public"), std::string::npos);
  }
  EXPECT_EQ(json::parse(http.get(sign("/v1/images/secret")).body)["private"], true);
  EXPECT_EQ(http.get("/dzi/open.dzi").header("cache-control").rfind("public", 0), 0u);
}

TEST_F(Private, SignatureParametersDoNotChangeTheView) {
  const auto plain_open = http.get("/v1/images/open/mesh?zoom=0.5&w=64&h=48");
  const auto signed_open = http.get(sign("/v1/images/open/mesh?zoom=0.5&w=64&h=48"));
  ASSERT_EQ(signed_open.status, 200);
  EXPECT_EQ(signed_open.header("etag"), plain_open.header("etag")) << "expires and sig are not part of the ETag";
  EXPECT_EQ(signed_open.body, plain_open.body);
  EXPECT_EQ(http.get("/v1/images/open/lines?expires=1&expires=2").status, 400) << "each at most once";
}

TEST_F(Private, ExpiredAndTamperedUrlsAreForbidden) {
  const api::UrlSigner signer = api::UrlSigner::from_file(key_file);
  const auto now = std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch());
  const auto expired = http.get(signer.sign("/dzi/secret.dzi", "", now.count() - 10));
  EXPECT_EQ(expired.status, 403);
  EXPECT_EQ(code(expired), "url_expired");

  const std::string view = sign("/v1/images/secret/viewport?zoom=0.5&w=64&h=48");
  ASSERT_EQ(http.get(view).status, 200);
  std::string other_image = view, other_query = view, later = view;
  other_image.replace(other_image.find("secret"), 6, "other");
  other_query.replace(other_query.find("w=64"), 4, "w=65");
  later.replace(later.find("expires=") + 8, 1, "9");
  std::string flipped = view;
  flipped.back() = flipped.back() == '0' ? '1' : '0';
  for (const auto& tampered : {other_image, other_query, later, flipped}) {
    SCOPED_TRACE(tampered);
    const auto r = http.get(tampered);
    EXPECT_EQ(r.status, 403);
    EXPECT_EQ(code(r), "bad_signature");
  }
}

TEST_F(Private, AbsentFromTheListWithoutAKey) {
  std::vector<std::string> ids;
  const json body = json::parse(http.get("/v1/images").body);
  for (const auto& image : body["images"]) ids.push_back(image["id"]);
  EXPECT_EQ(ids, std::vector<std::string>{"open"});
}

// The response cache is shared by every client: an answer cached for a signed request must not
// reach an unsigned one, neither on the I/O thread's fast path nor as a 304.
TEST_F(Private, NoLeakThroughTheSharedCache) {
  for (const std::string target : {"/dzi/secret_files/8/0_0.jpg", "/iiif/3/secret/info.json"}) {
    SCOPED_TRACE(target);
    const auto first = http.get(sign(target));
    ASSERT_EQ(first.status, 200);
    ASSERT_EQ(http.get(sign(target)).status, 200);
    EXPECT_EQ(http.get(target).status, 404);
    EXPECT_EQ(http.get(target, {{"If-None-Match", first.header("etag")}}).status, 404);
  }
}

TEST_F(Private, EditsKeepItPrivateAndAReUploadSaysAgain) {
  ASSERT_EQ(http.request("PUT", "/v1/images/secret/lines", R"({"lines": [[10, 10, 400, 10]]})",
                         {{"Content-Type", "application/json"}}).status, 200);
  EXPECT_EQ(http.get("/v1/images/secret").status, 404) << "the edit published a version that is still private";
  const auto edited = http.get(sign("/v1/images/secret/lines"));
  ASSERT_EQ(edited.status, 200);
  EXPECT_EQ(json::parse(edited.body)["lines"].size(), 1u);

  const std::string jpg = testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg");
  ASSERT_EQ(http.request("POST", "/v1/images?id=secret", jpg).status, 201);
  EXPECT_EQ(http.get("/v1/images/secret").status, 200) << "re-uploaded without private=: public";
  const auto bad = http.request("POST", "/v1/images?id=x&private=yes", jpg);
  EXPECT_EQ(bad.status, 400);
  EXPECT_EQ(http.get("/v1/images/x").status, 404) << "nothing stored";
}

// With keys: a curator key reads private images and sees them listed; a reader key does not.
class PrivateWithKeys : public ::testing::Test {
 protected:
  testing::TempDir dir;
  const std::string curator = "Bearer curator-key-CCCCCCCCCCCCCCCC";
  const std::string reader = "Bearer reader-key-RRRRRRRRRRRRRRRR";
  const std::string keys_file = [this] {
    const std::string path = dir.path() + "/keys";
    std::ofstream(path) << "cur curator " << curator.substr(7) << "\nrd reader " << reader.substr(7) << "\n";
    return path;
  }();
  testing::ServerProcess server{dir.path() + "/store", {"--keys", keys_file}};
  HttpClient http{server.port()};

  void SetUp() override {
    const std::string jpg = testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg");
    ASSERT_EQ(http.request("POST", "/v1/images?id=secret&private=true", jpg, {{"Authorization", curator}}).status, 201);
  }

  std::vector<std::string> listed(const std::map<std::string, std::string>& headers) {
    std::vector<std::string> ids;
    const json body = json::parse(http.get("/v1/images", headers).body);
    for (const auto& image : body["images"]) ids.push_back(image["id"]);
    return ids;
  }
};

TEST_F(PrivateWithKeys, ListedAndReadableForCuratorsOnly) {
  EXPECT_TRUE(listed({}).empty());
  EXPECT_TRUE(listed({{"Authorization", reader}}).empty());
  EXPECT_EQ(listed({{"Authorization", curator}}), std::vector<std::string>{"secret"});
  EXPECT_EQ(http.get("/v1/images", {{"Authorization", curator}}).header("cache-control"), "private, no-cache");
  for (const std::string target : {"/v1/images/secret", "/dzi/secret.dzi", "/iiif/3/secret/info.json",
                                   "/v1/images/secret/mesh?w=64&h=48"}) {
    SCOPED_TRACE(target);
    EXPECT_EQ(http.get(target, {{"Authorization", reader}}).status, 404);
    const auto r = http.get(target, {{"Authorization", curator}});
    EXPECT_EQ(r.status, 200);
    EXPECT_EQ(r.header("cache-control").rfind("private", 0), 0u) << r.header("cache-control");
  }
}

// Read with a key first (the answer is cached), then without: still refused.
TEST_F(PrivateWithKeys, NoLeakThroughTheSharedCache) {
  const std::string tile = "/dzi/secret_files/9/0_0.jpg";
  const auto first = http.get(tile, {{"Authorization", curator}});
  ASSERT_EQ(first.status, 200);
  ASSERT_EQ(http.get(tile, {{"Authorization", curator}}).status, 200);
  EXPECT_EQ(http.get(tile).status, 404);
  EXPECT_EQ(http.get(tile, {{"Authorization", reader}}).status, 404);
  EXPECT_EQ(http.get(tile, {{"If-None-Match", first.header("etag")}}).status, 404);
}

TEST(PrivateSign, UsageMistakesExit2) {
  testing::TempDir dir;
  const std::string key = write_secret(dir.path());
  const std::string bin = testing::zoomwarp_binary();
  EXPECT_EQ(testing::run_command({bin, "sign", "/dzi/a.dzi", "--expires", "1y", "--signing-key", key}).exit_code, 2);
  EXPECT_EQ(testing::run_command({bin, "sign", "/dzi/a.dzi"}).exit_code, 2) << "no key";
  EXPECT_EQ(testing::run_command({bin, "sign", "dzi", "--signing-key", key}).exit_code, 2) << "not a path";
  const auto help = testing::run_command({bin, "sign", "--help"});
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("--expires"), std::string::npos);
}

}  // namespace
}  // namespace zoomwarp
