// IIIF Presentation 3.0 and the curator's description on the wire (api/presentation.h,
// api/description.h): an image's manifest as a IIIF viewer loads it (and then its image service),
// PUT/GET /v1/images/{id}/metadata with keys, If-Match and refusals that publish nothing, the
// description kept through edits and re-ingests and set by an upload's query, the paged collection
// of public images, and private images' manifests whose image service is opened by a service token.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "api/url_signing.h"
#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/json_schema.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HttpClient;
using testing::HttpResponse;
using Headers = std::map<std::string, std::string>;

constexpr const char* kSecretHex = "00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff";
const std::string kCuratorKey = "curator-key-CCCCCCCCCCCCCCCC";
const std::string kReaderKey = "reader-key-RRRRRRRRRRRRRRRR";
const Headers kCurator = {{"Authorization", "Bearer " + kCuratorKey}};
const Headers kReader = {{"Authorization", "Bearer " + kReaderKey}};
const Headers kJsonCurator = {{"Authorization", "Bearer " + kCuratorKey}, {"Content-Type", "application/json"}};
Headers if_match(const std::string& etag) {
  Headers h = kJsonCurator;
  h["If-Match"] = etag;
  return h;
}

std::int64_t unix_now() {
  return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// A PNG of w × h, quick to ingest.
std::string png(int w, int h) {
  testing::TempDir dir;
  const std::string path = dir.path() + "/p.png";
  testing::write_image(path, testing::test_pattern(w, h, 3), 8);
  return testing::read_file(path);
}

std::string error_code(const HttpResponse& r) {
  const json body = json::parse(r.body, nullptr, false);
  return body.is_object() && body.contains("error") ? body["error"].value("code", "") : "";
}

// The painting annotation's body of a manifest's one canvas.
const json& painting_body(const json& manifest) { return manifest["items"][0]["items"][0]["items"][0]["body"]; }

// A server with keys (curator, reader) and a signing key, on a fresh store.
class IiifPresentation : public ::testing::Test {
 protected:
  // What a derived fixture puts in the store (DIR, STORE) before the server starts.
  using Prepare = std::function<void(const std::string& dir, const std::string& store)>;
  IiifPresentation() = default;
  explicit IiifPresentation(Prepare prepare) : prepare_(std::move(prepare)) {}

  Prepare prepare_;  // first: the members below start the server
  testing::TempDir dir;
  const std::string store = dir.path() + "/store";
  const std::string signing_key = [this] {
    const std::string path = dir.path() + "/signing.key";
    std::ofstream(path) << kSecretHex << "\n";
    return path;
  }();
  const std::string keys = [this] {
    const std::string path = dir.path() + "/keys";
    std::ofstream(path) << "cur curator " << kCuratorKey << "\nrd reader " << kReaderKey << "\n";
    return path;
  }();
  std::unique_ptr<testing::ServerProcess> server = start();
  HttpClient http{server->port()};
  const std::string origin = "http://127.0.0.1:" + std::to_string(server->port());
  const std::string image_png = png(640, 480);

  std::unique_ptr<testing::ServerProcess> start() {
    if (prepare_) prepare_(dir.path(), store);
    return std::make_unique<testing::ServerProcess>(store, std::vector<std::string>{"--keys", keys, "--signing-key", signing_key});
  }

  void upload(const std::string& id, const std::string& query = "", const std::string& body = "") {
    const auto r = http.request("POST", "/v1/images?id=" + id + query, body.empty() ? image_png : body, kCurator);
    ASSERT_EQ(r.status, 201) << r.body;
  }
  json image(const std::string& id) {
    const auto r = http.get("/v1/images/" + id, kCurator);
    EXPECT_EQ(r.status, 200) << r.body;
    return json::parse(r.body, nullptr, false);
  }
  std::string version(const std::string& id) { return image(id).value("version", ""); }
  std::string etag(const std::string& id) { return http.get("/v1/images/" + id, kCurator).header("etag"); }
  json metadata(const std::string& id) {
    const auto r = http.get("/v1/images/" + id + "/metadata", kCurator);
    EXPECT_EQ(r.status, 200) << r.body;
    return json::parse(r.body, nullptr, false);
  }
  json manifest(const std::string& id, const Headers& headers = {}) {
    const auto r = http.get("/iiif/presentation/3/" + id + "/manifest", headers);
    EXPECT_EQ(r.status, 200) << r.body;
    return json::parse(r.body, nullptr, false);
  }
  HttpResponse put_metadata(const std::string& id, const std::string& body, Headers headers = kJsonCurator) {
    return http.request("PUT", "/v1/images/" + id + "/metadata", body, headers);
  }
  // An absolute URL of this server as a target.
  std::string target(const std::string& url) {
    EXPECT_EQ(url.rfind(origin, 0), 0u) << url;
    return url.substr(origin.size());
  }
  std::string target(const json& url) { return target(url.get<std::string>()); }
  json openapi() { return json::parse(http.get("/openapi.json").body); }
};

const char* kDescription = R"({
  "label": {"en": ["Boats on the lake"], "fr": ["Bateaux sur le lac"]},
  "summary": "Evening, late summer.",
  "metadata": [{"label": "Place", "value": {"en": ["Lake"]}}, {"label": "Year", "value": "2024"}],
  "rights": "http://creativecommons.org/licenses/by/4.0/",
  "requiredStatement": {"label": "Attribution", "value": "Photo: A. Person"}
})";

// The same description as the server stores and answers it: plain strings as {"none": [...]}.
json described() {
  return json::parse(R"({
    "label": {"en": ["Boats on the lake"], "fr": ["Bateaux sur le lac"]},
    "summary": {"none": ["Evening, late summer."]},
    "metadata": [{"label": {"none": ["Place"]}, "value": {"en": ["Lake"]}},
                 {"label": {"none": ["Year"]}, "value": {"none": ["2024"]}}],
    "rights": "http://creativecommons.org/licenses/by/4.0/",
    "requiredStatement": {"label": {"none": ["Attribution"]}, "value": {"none": ["Photo: A. Person"]}}
  })");
}

TEST_F(IiifPresentation, AManifestAViewerCanOpen) {
  upload("boats");
  const auto r = http.get("/iiif/presentation/3/boats/manifest", {{"Origin", "https://viewer.example.org"}});
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.header("access-control-allow-origin"), "*") << "viewers on other origins load it";
  EXPECT_EQ(r.header("content-type").rfind("application/json", 0), 0u) << r.header("content-type");
  EXPECT_EQ(r.header("cache-control").rfind("public", 0), 0u) << r.header("cache-control");
  const json m = json::parse(r.body);
  const json doc = openapi();
  EXPECT_EQ(testing::validate_json(m, doc["components"]["schemas"]["IiifManifest"], doc), std::vector<std::string>{});
  EXPECT_EQ(m["id"], origin + "/iiif/presentation/3/boats/manifest");
  EXPECT_EQ(m["label"], json::parse(R"({"none": ["boats"]})")) << "no description: the id";
  EXPECT_EQ(m["items"][0]["width"], 640);
  EXPECT_EQ(m["items"][0]["height"], 480);
  EXPECT_EQ(m["partOf"][0]["id"], origin + "/iiif/presentation/3/collection");
  // What the viewer does next: the image service, the painted image and the thumbnail, each the
  // size the manifest says.
  const json& body = painting_body(m);
  const auto info = http.get(target(body["service"][0]["id"].get<std::string>() + "/info.json"));
  ASSERT_EQ(info.status, 200);
  EXPECT_EQ(json::parse(info.body)["id"], body["service"][0]["id"]);
  for (const json& picture : {body, m["thumbnail"][0]}) {
    SCOPED_TRACE(picture["id"].get<std::string>());
    const auto pixels = http.get(target(picture["id"]));
    ASSERT_EQ(pixels.status, 200);
    EXPECT_EQ(pixels.header("content-type"), "image/jpeg");
    const tiles::Raster decoded = testing::decode_image(pixels.body);
    EXPECT_EQ(decoded.width, picture["width"].get<int>());
    EXPECT_EQ(decoded.height, picture["height"].get<int>());
  }
  EXPECT_EQ(m["thumbnail"][0]["width"], 320) << "the first level within 400 × 400";
  // Revalidation, and the JSON-LD form.
  ASSERT_FALSE(r.header("etag").empty());
  EXPECT_EQ(http.get("/iiif/presentation/3/boats/manifest", {{"If-None-Match", r.header("etag")}}).status, 304);
  const auto ld = http.get("/iiif/presentation/3/boats/manifest", {{"Accept", "application/ld+json"}});
  ASSERT_EQ(ld.status, 200);
  EXPECT_EQ(ld.header("content-type").rfind("application/ld+json;profile=\"http://iiif.io/api/presentation/3/context.json\"", 0), 0u)
      << ld.header("content-type");
  EXPECT_EQ(json::parse(ld.body), m);
  EXPECT_EQ(http.get("/iiif/presentation/3/nothing/manifest").status, 404);
}

TEST_F(IiifPresentation, InfoJsonAndTheImageRecordLinkToTheManifest) {
  upload("boats");
  const json info = json::parse(http.get("/iiif/3/boats/info.json").body);
  EXPECT_EQ(info["partOf"], json::parse(R"([{"id": ")" + origin + R"(/iiif/presentation/3/boats/manifest", "type": "Manifest"}])"));
  ASSERT_EQ(info["seeAlso"].size(), 1u);
  EXPECT_EQ(info["seeAlso"][0]["id"], origin + "/v1/images/boats");
  EXPECT_EQ(info["seeAlso"][0]["format"], "application/json");
  EXPECT_EQ(http.get(target(info["partOf"][0]["id"])).status, 200);
  EXPECT_EQ(http.get(target(info["seeAlso"][0]["id"])).status, 200);
  const json links = image("boats")["links"];
  EXPECT_EQ(links["manifest"], "/iiif/presentation/3/boats/manifest");
  EXPECT_EQ(links["metadata"], "/v1/images/boats/metadata");
  EXPECT_EQ(http.get(links["manifest"].get<std::string>()).status, 200);
  EXPECT_EQ(http.get(links["metadata"].get<std::string>()).status, 200);
  const json doc = openapi();
  EXPECT_EQ(testing::validate_json(image("boats"), doc["components"]["schemas"]["Image"], doc), std::vector<std::string>{});
}

TEST_F(IiifPresentation, PutMetadataPublishesAVersionThatTheManifestShows) {
  upload("boats");
  const std::string before = etag("boats"), old_version = version("boats");
  const auto old_manifest = http.get("/iiif/presentation/3/boats/manifest");
  EXPECT_EQ(metadata("boats"), json::object()) << "no description yet";

  const auto put = put_metadata("boats", kDescription, if_match(before));
  ASSERT_EQ(put.status, 200) << put.body;
  EXPECT_EQ(json::parse(put.body), described()) << "answered as stored";
  EXPECT_NE(version("boats"), old_version) << "a new version";
  EXPECT_NE(etag("boats"), before);
  EXPECT_EQ(put.header("etag"), etag("boats")) << "the new image ETag, for the next If-Match";

  const auto got = http.get("/v1/images/boats/metadata");
  ASSERT_EQ(got.status, 200);
  EXPECT_EQ(json::parse(got.body), described());
  EXPECT_EQ(got.header("etag"), etag("boats"));
  const json doc = openapi();
  EXPECT_EQ(testing::validate_json(json::parse(got.body), doc["components"]["schemas"]["Description"], doc),
            std::vector<std::string>{});

  const auto now = http.get("/iiif/presentation/3/boats/manifest", {{"If-None-Match", old_manifest.header("etag")}});
  ASSERT_EQ(now.status, 200) << "the manifest changed with the description: not a 304";
  const json m = json::parse(now.body);
  const json want = described();
  for (const char* member : {"label", "summary", "metadata", "rights", "requiredStatement"}) EXPECT_EQ(m[member], want[member]) << member;
  // A second PUT replaces the whole description: members left out are gone.
  ASSERT_EQ(put_metadata("boats", R"({"label": "Boats"})").status, 200);
  EXPECT_EQ(metadata("boats"), json::parse(R"({"label": {"none": ["Boats"]}})"));
  EXPECT_FALSE(manifest("boats").contains("rights"));
  EXPECT_EQ(put_metadata("nothing", kDescription).status, 404);
}

TEST_F(IiifPresentation, PutMetadataNeedsACuratorKey) {
  upload("boats");
  const std::string v = version("boats");
  const auto none = put_metadata("boats", kDescription, {{"Content-Type", "application/json"}});
  EXPECT_EQ(none.status, 401);
  EXPECT_EQ(error_code(none), "key_required");
  const auto reader = put_metadata("boats", kDescription, {{"Authorization", "Bearer " + kReaderKey}, {"Content-Type", "application/json"}});
  EXPECT_EQ(reader.status, 403);
  EXPECT_EQ(error_code(reader), "insufficient_role");
  EXPECT_EQ(version("boats"), v) << "nothing published";
  EXPECT_EQ(metadata("boats"), json::object());
  EXPECT_EQ(http.get("/v1/images/boats/metadata", kReader).status, 200) << "reading needs no curator";
}

TEST_F(IiifPresentation, AStaleIfMatchIsRefusedAndPublishesNothing) {
  upload("boats");
  const std::string stale = etag("boats");
  ASSERT_EQ(put_metadata("boats", R"({"label": "First"})").status, 200);
  const std::string v = version("boats");
  for (const std::string& tag : {stale, "W/" + etag("boats"), std::string("\"nonsense\"")}) {
    SCOPED_TRACE(tag);
    const auto r = put_metadata("boats", R"({"label": "Second"})", if_match(tag));
    EXPECT_EQ(r.status, 412);
    EXPECT_EQ(error_code(r), "precondition_failed");
  }
  EXPECT_EQ(version("boats"), v);
  EXPECT_EQ(metadata("boats")["label"], json::parse(R"({"none": ["First"]})"));
  const auto fresh = put_metadata("boats", R"({"label": "Second"})", if_match(etag("boats")));
  EXPECT_EQ(fresh.status, 200) << fresh.body;
  EXPECT_EQ(metadata("boats")["label"], json::parse(R"({"none": ["Second"]})"));
}

TEST_F(IiifPresentation, BadOrOversizeDescriptionsPublishNothing) {
  upload("boats");
  ASSERT_EQ(put_metadata("boats", kDescription).status, 200);
  const std::string v = version("boats");
  std::string pairs_257 = R"({"metadata": [)";
  for (int i = 0; i < 257; ++i) pairs_257 += std::string(i ? "," : "") + R"({"label": "k", "value": "v"})";
  pairs_257 += "]}";
  // Within 64 KiB as sent, over it as stored (indented): refused rather than stored unreadable.
  std::string expands = R"({"metadata":[)";
  for (int i = 0; i < 250; ++i) {
    expands += std::string(i ? "," : "") + R"({"label":{"en":[)";
    for (int k = 0; k < 30; ++k) expands += std::string(k ? "," : "") + "\"k\"";
    expands += R"(]},"value":"v"})";
  }
  expands += "]}";
  ASSERT_LT(expands.size(), 64u * 1024);
  const std::string huge_label = R"({"label": ")" + std::string(64 * 1024, 'x') + R"("})";
  struct Case {
    std::string body;
    int status;
    std::string code;
  };
  for (const Case& c : std::vector<Case>{
           {"not json", 400, "invalid_body"},
           {R"({"title": "Boats"})", 400, "invalid_body"},
           {R"({"label": {"en_GB": ["Boats"]}})", 400, "invalid_body"},
           {R"({"label": {"en": []}})", 400, "invalid_body"},
           {R"({"label": {"en": [1]}})", 400, "invalid_body"},
           {R"({"rights": "https://creativecommons.org/licenses/by/4.0/"})", 400, "invalid_body"},
           {huge_label, 413, "description_too_large"},
           {expands, 413, "description_too_large"},
           {pairs_257, 413, "too_many_metadata"},
           {std::string(2 << 20, ' '), 413, "body_too_large"},
       }) {
    SCOPED_TRACE(c.body.substr(0, 60));
    const auto r = put_metadata("boats", c.body);
    EXPECT_EQ(r.status, c.status) << r.body;
    EXPECT_EQ(error_code(r), c.code) << r.body;
  }
  EXPECT_EQ(version("boats"), v) << "nothing published";
  EXPECT_EQ(metadata("boats"), described());
  EXPECT_EQ(manifest("boats")["label"], described()["label"]);
  EXPECT_EQ(http.get("/iiif/presentation/3/collection/1").status, 200);
}

TEST_F(IiifPresentation, TheDescriptionSurvivesEditsAndReUploads) {
  upload("boats");
  ASSERT_EQ(put_metadata("boats", kDescription).status, 200);
  std::string v = version("boats");

  const auto lines = http.request("PUT", "/v1/images/boats/lines", R"({"lines": [[10, 100, 300, 100]]})", kJsonCurator);
  ASSERT_EQ(lines.status, 200) << lines.body;
  EXPECT_NE(version("boats"), v);
  EXPECT_EQ(metadata("boats"), described()) << "after a lines edit";
  v = version("boats");

  upload("boats", "", png(320, 240));  // new pixels, no description fields
  EXPECT_NE(version("boats"), v);
  EXPECT_EQ(image("boats")["width"], 320);
  EXPECT_EQ(metadata("boats"), described()) << "after a re-upload without description fields";
  EXPECT_EQ(manifest("boats")["items"][0]["width"], 320);
  EXPECT_EQ(manifest("boats")["label"], described()["label"]);

  upload("boats", "&label=Ships");
  json want = described();
  want["label"] = json::parse(R"({"none": ["Ships"]})");
  EXPECT_EQ(metadata("boats"), want) << "label= replaces the label alone";
  EXPECT_EQ(manifest("boats")["label"], want["label"]);

  // `zoomwarp ingest` of the id, by another process on the same store.
  v = version("boats");
  const std::string file = dir.path() + "/boats.png";
  std::ofstream(file, std::ios::binary) << png(200, 100);
  const auto run = testing::run_command(
      {testing::zoomwarp_binary(), "ingest", file, "--id", "boats", "--store", store, "--quiet"});
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (int i = 0; i < 100 && version("boats") == v; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_NE(version("boats"), v) << "the server sees the re-ingest";
  EXPECT_EQ(image("boats")["width"], 200);
  EXPECT_EQ(metadata("boats"), want) << "after zoomwarp ingest";
}

TEST_F(IiifPresentation, AnUploadSetsTheDescriptionFromItsQuery) {
  upload("boats",
         "&label=Boats%20at%20dusk&summary=On%20the%20lake&rights=http%3A%2F%2Frightsstatements.org%2Fvocab%2FInC%2F1.0%2F"
         "&attribution=Photo%3A%20A.%20Person");
  EXPECT_EQ(metadata("boats"), json::parse(R"({
    "label": {"none": ["Boats at dusk"]},
    "summary": {"none": ["On the lake"]},
    "rights": "http://rightsstatements.org/vocab/InC/1.0/",
    "requiredStatement": {"label": {"none": ["Attribution"]}, "value": {"none": ["Photo: A. Person"]}}
  })"));
  EXPECT_EQ(manifest("boats")["label"], json::parse(R"({"none": ["Boats at dusk"]})"));
  const std::string v = version("boats");
  // Refused uploads store nothing, for a new id as for an existing one.
  for (const std::string query : {"&rights=https%3A%2F%2Fcreativecommons.org%2Flicenses%2Fby%2F4.0%2F", "&rights=CC-BY",
                                  "&label=", "&label=%FF%FE", "&title=Boats"}) {
    SCOPED_TRACE(query);
    for (const std::string id : {"boats", "fresh"}) {
      const auto r = http.request("POST", "/v1/images?id=" + id + query, image_png, kCurator);
      EXPECT_EQ(r.status, 400) << r.body;
      EXPECT_EQ(error_code(r), "invalid_query") << r.body;
    }
    EXPECT_EQ(version("boats"), v);
    EXPECT_EQ(http.get("/v1/images/fresh", kCurator).status, 404);
  }
  EXPECT_EQ(metadata("boats")["label"], json::parse(R"({"none": ["Boats at dusk"]})"));
}

TEST_F(IiifPresentation, AnEmptyStoreHasAnEmptyCollection) {
  const auto r = http.get("/iiif/presentation/3/collection");
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.header("access-control-allow-origin"), "*");
  const json c = json::parse(r.body);
  EXPECT_EQ(c["id"], origin + "/iiif/presentation/3/collection");
  EXPECT_EQ(c["type"], "Collection");
  EXPECT_TRUE(c["items"].empty());
  EXPECT_EQ(http.get("/iiif/presentation/3/collection/1").status, 404) << "no pages at all";
}

// 101 public images (ingested by the CLI before the server starts) and a private one.
class IiifPresentationCollection : public IiifPresentation {
 protected:
  IiifPresentationCollection() : IiifPresentation(&fill) {}
  static void fill(const std::string& dir, const std::string& store) {
    const std::string folder = dir + "/many";
    fs::create_directories(folder);
    const std::string tiny = png(8, 6);
    for (int i = 0; i < 101; ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "/img%03d.png", i);
      std::ofstream(folder + name, std::ios::binary) << tiny;
    }
    const auto run = testing::run_command(
        {testing::zoomwarp_binary(), "ingest", folder, "--store", store, "--jobs", "2", "--quiet"});
    if (run.exit_code != 0) throw std::runtime_error("ingest failed: " + run.output);
  }
};

TEST_F(IiifPresentationCollection, ListsPublicImagesInPagesOfAHundred) {
  upload("aaa-secret", "&private=true");  // first by id: it would head page 1 if listed
  ASSERT_EQ(put_metadata("img050", R"({"label": {"en": ["Fifty"]}})").status, 200);
  const json doc = openapi();
  for (const Headers& headers : {Headers{}, kCurator}) {
    SCOPED_TRACE(headers.empty() ? "no key" : "curator key");
    const auto r = http.get("/iiif/presentation/3/collection", headers);
    ASSERT_EQ(r.status, 200);
    const json c = json::parse(r.body);
    EXPECT_EQ(testing::validate_json(c, doc["components"]["schemas"]["IiifCollection"], doc), std::vector<std::string>{});
    ASSERT_EQ(c["items"].size(), 2u);
    EXPECT_EQ(c["items"][0]["label"]["none"][0], "Images 1–100 of 101") << "the private image is not counted";
    EXPECT_EQ(c["items"][1]["label"]["none"][0], "Images 101–101 of 101");

    const auto first = http.get(target(c["items"][0]["id"]), headers);
    ASSERT_EQ(first.status, 200);
    const json p1 = json::parse(first.body);
    EXPECT_EQ(testing::validate_json(p1, doc["components"]["schemas"]["IiifCollection"], doc), std::vector<std::string>{});
    ASSERT_EQ(p1["items"].size(), 100u);
    EXPECT_EQ(p1["items"][0]["id"], origin + "/iiif/presentation/3/img000/manifest") << "in id order, no private image";
    EXPECT_EQ(p1["items"][99]["id"], origin + "/iiif/presentation/3/img099/manifest");
    EXPECT_EQ(p1["items"][50]["label"], json::parse(R"({"en": ["Fifty"]})"));
    EXPECT_EQ(p1["items"][51]["label"], json::parse(R"({"none": ["img051"]})"));
    for (const json& item : p1["items"]) EXPECT_EQ(item["type"], "Manifest");
    EXPECT_EQ(r.body.find("aaa-secret"), std::string::npos);
    EXPECT_EQ(first.body.find("aaa-secret"), std::string::npos);

    const json p2 = json::parse(http.get(target(c["items"][1]["id"]), headers).body);
    ASSERT_EQ(p2["items"].size(), 1u);
    EXPECT_EQ(p2["items"][0]["id"], origin + "/iiif/presentation/3/img100/manifest");
    EXPECT_EQ(p2["partOf"][0]["id"], origin + "/iiif/presentation/3/collection");
    // The references open.
    const json m = manifest("img100");
    EXPECT_EQ(m["items"][0]["width"], 8);
    EXPECT_EQ(http.get(target(p2["items"][0]["thumbnail"][0]["id"])).status, 200);
  }
  for (const std::string page : {"0", "3", "999999", "x", "-1", "1.0"}) {
    SCOPED_TRACE(page);
    const auto r = http.get("/iiif/presentation/3/collection/" + page);
    EXPECT_EQ(r.status, 404);
    EXPECT_EQ(error_code(r), "not_found");
  }
  // Deleting one takes the collection back to one page.
  ASSERT_EQ(http.request("DELETE", "/v1/images/img007", "", kCurator).status, 204);
  const json c = json::parse(http.get("/iiif/presentation/3/collection").body);
  ASSERT_EQ(c["items"].size(), 1u);
  EXPECT_EQ(c["items"][0]["label"]["none"][0], "Images 1–100 of 100");
  EXPECT_EQ(http.get("/iiif/presentation/3/collection/2").status, 404);
}

// Issue 42: one damaged description.json (a store written by hand, a cut copy) no longer makes
// the collection's page a 500: the image is listed with its id as its label, the others with
// theirs. And the collection, made once per store state, follows this server's own changes at
// once.
TEST_F(IiifPresentation, ADamagedDescriptionIsLeftOutOfTheCollectionNotA500) {
  upload("boats", "&label=Boats");
  upload("lake", "&label=Lake");
  for (const auto& e : std::filesystem::directory_iterator(store + "/versions"))
    if (e.path().filename().string().starts_with("lake@")) std::ofstream(e.path() / "description.json") << "{ damaged";
  const auto page = http.get("/iiif/presentation/3/collection/1");
  ASSERT_EQ(page.status, 200) << page.body;
  const json p = json::parse(page.body);
  ASSERT_EQ(p["items"].size(), 2u);
  EXPECT_EQ(p["items"][0]["label"], json::parse(R"({"none": ["Boats"]})"));
  EXPECT_EQ(p["items"][1]["label"], json::parse(R"({"none": ["lake"]})")) << "listed, its description left out";
  upload("river", "&label=River");
  const json after = json::parse(http.get("/iiif/presentation/3/collection/1").body);
  ASSERT_EQ(after["items"].size(), 3u) << "this server's upload is listed at once";
  EXPECT_EQ(after["items"][2]["label"], json::parse(R"({"none": ["River"]})"));
}

// A private image's manifest: for a curator key or a signed URL only, and its image service
// signed as a whole, so that a viewer given the manifest loads the image without a key.
class IiifPresentationPrivate : public IiifPresentation {
 protected:
  void SetUp() override {
    upload("secret", "&private=true&label=Hidden");
    upload("other", "&private=true");
    upload("open");
  }
  const api::UrlSigner signer = api::UrlSigner::from_file(signing_key);

  // The service id of a manifest, as a target, and the expiry its token holds.
  std::pair<std::string, std::int64_t> service(const json& m) {
    const std::string service = target(painting_body(m)["service"][0]["id"]);
    const std::string prefix = "/iiif/3/secret~";
    EXPECT_EQ(service.rfind(prefix, 0), 0u) << service;
    const std::size_t second = service.find('~', prefix.size());
    return {service, std::stoll(service.substr(prefix.size(), second - prefix.size()))};
  }
};

TEST_F(IiifPresentationPrivate, TheManifestIsForCuratorsAndSignedUrlsOnly) {
  for (const Headers& headers : {Headers{}, kReader}) {
    const auto r = http.get("/iiif/presentation/3/secret/manifest", headers);
    EXPECT_EQ(r.status, 404);
    EXPECT_EQ(error_code(r), "image_not_found") << "as for an image that does not exist";
    EXPECT_EQ(http.get("/v1/images/secret/metadata", headers).status, 404);
  }
  const auto with_key = http.get("/iiif/presentation/3/secret/manifest", kCurator);
  ASSERT_EQ(with_key.status, 200);
  EXPECT_EQ(with_key.header("cache-control"), "private, no-store");
  const json m = json::parse(with_key.body);
  EXPECT_EQ(m["label"], json::parse(R"({"none": ["Hidden"]})"));
  EXPECT_FALSE(m.contains("partOf")) << "not in the public collection";
  const auto [service_id, expires] = service(m);
  EXPECT_NEAR(double(expires), double(unix_now() + 3600), 60) << "an hour with a key";
  EXPECT_EQ(m["thumbnail"][0]["service"][0]["id"], origin + service_id);
  EXPECT_EQ(target(m["thumbnail"][0]["id"]).rfind(service_id + "/full/", 0), 0u);

  const std::int64_t until = unix_now() + 600;
  const auto signed_get = http.get(signer.sign("/iiif/presentation/3/secret/manifest", "", until));
  ASSERT_EQ(signed_get.status, 200) << signed_get.body;
  EXPECT_EQ(signed_get.header("cache-control"), "private, no-store");
  EXPECT_EQ(service(json::parse(signed_get.body)).second, until) << "the token ends with the signed URL";
  const auto metadata_signed = http.get(signer.sign("/v1/images/secret/metadata", "", until));
  EXPECT_EQ(metadata_signed.status, 200);
  EXPECT_EQ(metadata_signed.header("cache-control").rfind("private", 0), 0u);

  // A key's request cannot stretch its token by adding an unsigned expiry of its own.
  const auto stretched = http.get("/iiif/presentation/3/secret/manifest?expires=99999999999", kCurator);
  ASSERT_EQ(stretched.status, 200);
  EXPECT_NEAR(double(service(json::parse(stretched.body)).second), double(unix_now() + 3600), 60);

  const auto expired = http.get(signer.sign("/iiif/presentation/3/secret/manifest", "", unix_now() - 10));
  EXPECT_EQ(expired.status, 403);
  EXPECT_EQ(error_code(expired), "url_expired");
  std::string tampered = signer.sign("/iiif/presentation/3/secret/manifest", "", until);
  tampered.back() = tampered.back() == '0' ? '1' : '0';
  EXPECT_EQ(http.get(tampered).status, 403);
}

TEST_F(IiifPresentationPrivate, ItsServiceTokenOpensTheImageServiceWithoutAKey) {
  const json m = manifest("secret", kCurator);
  const std::string token_service = service(m).first;
  const auto info = http.get(token_service + "/info.json");
  ASSERT_EQ(info.status, 200) << info.body;
  EXPECT_EQ(info.header("cache-control").rfind("private", 0), 0u) << info.header("cache-control");
  EXPECT_EQ(json::parse(info.body)["id"], origin + token_service) << "the viewer's tile requests carry the token";
  EXPECT_EQ(json::parse(info.body)["width"], 640);
  const auto tile = http.get(token_service + "/0,0,256,256/256,/0/default.jpg");
  ASSERT_EQ(tile.status, 200);
  EXPECT_EQ(testing::decode_image(tile.body).width, 256);
  const auto full = http.get(target(painting_body(m)["id"]));
  ASSERT_EQ(full.status, 200);
  EXPECT_EQ(testing::decode_image(full.body).width, 640);
  EXPECT_EQ(http.get(target(m["thumbnail"][0]["id"])).status, 200);
  EXPECT_EQ(http.get(token_service).status, 303) << "the base URI redirects to its info.json";
  EXPECT_EQ(http.get("/iiif/3/secret/info.json").status, 404) << "without the token, still private";
  EXPECT_EQ(http.get("/dzi/secret.dzi").status, 404) << "the token opens the IIIF image service only";

  auto code_of = [&](const std::string& t) {
    const auto r = http.get(t);
    return std::to_string(r.status) + " " + error_code(r);
  };
  const std::string expired = signer.sign_service("secret", unix_now() - 10);
  EXPECT_EQ(code_of("/iiif/3/" + expired + "/info.json"), "403 url_expired");
  EXPECT_EQ(code_of("/iiif/3/" + expired + "/full/64,/0/default.jpg"), "403 url_expired");
  std::string flipped = token_service;
  flipped.back() = flipped.back() == '0' ? '1' : '0';
  EXPECT_EQ(code_of(flipped + "/info.json"), "403 bad_signature");
  EXPECT_EQ(code_of(flipped + "/full/64,/0/default.jpg"), "403 bad_signature");
  std::string later = token_service;
  later.replace(later.find('~') + 1, 1, "9");
  EXPECT_EQ(code_of(later + "/info.json"), "403 bad_signature") << "a later expiry";
  // Secret's token does not open other (another private image).
  std::string on_other = token_service;
  on_other.replace(on_other.find("secret"), 6, "other");
  EXPECT_EQ(code_of(on_other + "/info.json"), "403 bad_signature");
  EXPECT_EQ(code_of(on_other + "/full/64,/0/default.jpg"), "403 bad_signature");
  EXPECT_EQ(code_of("/iiif/3/other/info.json"), "404 image_not_found");
  // A token signed for other opens other.
  EXPECT_EQ(http.get("/iiif/3/" + signer.sign_service("other", unix_now() + 60) + "/info.json").status, 200);
}

TEST_F(IiifPresentationPrivate, APublicImagesManifestNeedsNoToken) {
  const json m = manifest("open");
  EXPECT_EQ(painting_body(m)["service"][0]["id"], origin + "/iiif/3/open");
  EXPECT_EQ(m["partOf"][0]["id"], origin + "/iiif/presentation/3/collection");
}

}  // namespace
}  // namespace zoomwarp
