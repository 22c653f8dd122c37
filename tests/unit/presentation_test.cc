// IIIF Presentation 3.0 documents (api/presentation.h): what a IIIF viewer (Mirador, the
// Universal Viewer) reads from an image's manifest and from the collection of public images.
// Expected sizes are worked out by hand from the image size, the pyramid's halving and the
// service's limits, not by the planning code under test.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "api/description.h"
#include "api/presentation.h"

namespace zoomwarp {
namespace {

using nlohmann::json;

const std::string kBase = "https://tiles.example.org";
const std::string kContext = "http://iiif.io/api/presentation/3/context.json";

tiles::Manifest image(const std::string& id, int w, int h) {
  tiles::Manifest m;
  m.id = id;
  m.version = "v1";
  m.width = w;
  m.height = h;
  m.levels = tiles::pyramid_levels(w, h);
  return m;
}

api::ManifestLinks links_of(const std::string& id, bool in_collection = true) {
  return {kBase, kBase + "/iiif/3/" + id, in_collection};
}

json manifest(const tiles::Manifest& m, const api::Description& d = {}, const api::ManifestLinks* links = nullptr,
              const api::IiifLimits& limits = {}) {
  return json::parse(api::manifest_json(m, d, links ? *links : links_of(m.id), limits));
}

// The painting annotation of the manifest's one canvas.
const json& painting(const json& manifest) { return manifest["items"][0]["items"][0]["items"][0]; }

TEST(PresentationManifest, OneCanvasTheSizeOfTheImagePaintedByItsImageService) {
  const json doc = manifest(image("boats", 4000, 2000));
  EXPECT_EQ(doc["@context"], kContext);
  EXPECT_EQ(doc["id"], kBase + "/iiif/presentation/3/boats/manifest");
  EXPECT_EQ(doc["type"], "Manifest");
  ASSERT_EQ(doc["items"].size(), 1u);
  const json& canvas = doc["items"][0];
  EXPECT_EQ(canvas["type"], "Canvas");
  EXPECT_EQ(canvas["width"], 4000);
  EXPECT_EQ(canvas["height"], 2000);
  EXPECT_EQ(canvas["items"][0]["type"], "AnnotationPage");
  const json& a = painting(doc);
  EXPECT_EQ(a["type"], "Annotation");
  EXPECT_EQ(a["motivation"], "painting");
  EXPECT_EQ(a["target"], canvas["id"]);
  EXPECT_EQ(a["body"]["type"], "Image");
  EXPECT_EQ(a["body"]["format"], "image/jpeg");
  EXPECT_EQ(a["body"]["id"], kBase + "/iiif/3/boats/full/max/0/default.jpg");
  EXPECT_EQ(a["body"]["width"], 4000) << "within the default limits: the image's own size";
  EXPECT_EQ(a["body"]["height"], 2000);
  ASSERT_EQ(a["body"]["service"].size(), 1u);
  EXPECT_EQ(a["body"]["service"][0],
            json::parse(R"({"id": "https://tiles.example.org/iiif/3/boats", "type": "ImageService3", "profile": "level2"})"));
  EXPECT_EQ(doc["seeAlso"][0]["id"], kBase + "/v1/images/boats");
  EXPECT_EQ(doc["seeAlso"][0]["format"], "application/json");
}

// The body is what `full/max` answers: for an image over the service's limits, the largest size
// within them, so a viewer that asks for the body's URL gets the width and height it was told.
TEST(PresentationManifest, TheBodyIsFullMaxWithinTheServicesLimits) {
  const tiles::Manifest m = image("wide", 4000, 2000);
  // maxWidth binds: 4000 → 1000 (a quarter), 2000 → 500.
  json a = painting(manifest(m, {}, nullptr, api::IiifLimits{1000, 1000, 1000LL * 1000}));
  EXPECT_EQ(a["body"]["width"], 1000);
  EXPECT_EQ(a["body"]["height"], 500);
  // maxArea binds: 500 000 px of 8 000 000 is a scale of 1/4 again.
  a = painting(manifest(m, {}, nullptr, api::IiifLimits{8192, 8192, 500000}));
  EXPECT_EQ(a["body"]["width"], 1000);
  EXPECT_EQ(a["body"]["height"], 500);
  // maxHeight binds on a tall image: 3000 × 9000 → 1000 × 3000.
  a = painting(manifest(image("tall", 3000, 9000), {}, nullptr, api::IiifLimits{8192, 3000, 1LL << 40}));
  EXPECT_EQ(a["body"]["width"], 1000);
  EXPECT_EQ(a["body"]["height"], 3000);
  // The canvas keeps the image's own size: annotations are in full-resolution pixels.
  EXPECT_EQ(manifest(m, {}, nullptr, api::IiifLimits{1000, 1000, 1000LL * 1000})["items"][0]["width"], 4000);
}

// The thumbnail is the whole image at the first pyramid level within 400 × 400 (level k is
// ceil(w / 2^k) × ceil(h / 2^k)): a size the service reads from one level.
TEST(PresentationManifest, TheThumbnailIsAPyramidLevelWithin400By400) {
  struct Case {
    int w, h, tw, th;
  };
  for (const Case c : {Case{4000, 2000, 250, 125}, Case{1001, 999, 251, 250}, Case{300, 200, 300, 200},
                       Case{400, 400, 400, 400}, Case{401, 10, 201, 5}, Case{800, 801, 200, 201},
                       Case{100000, 50, 391, 1}}) {
    SCOPED_TRACE(std::to_string(c.w) + "x" + std::to_string(c.h));
    const json doc = manifest(image("t", c.w, c.h));
    ASSERT_EQ(doc["thumbnail"].size(), 1u);
    const json& t = doc["thumbnail"][0];
    EXPECT_EQ(t["width"], c.tw);
    EXPECT_EQ(t["height"], c.th);
    EXPECT_LE(t["width"].get<int>(), 400);
    EXPECT_LE(t["height"].get<int>(), 400);
    EXPECT_EQ(t["id"], kBase + "/iiif/3/t/full/" + std::to_string(c.tw) + "," + std::to_string(c.th) + "/0/default.jpg");
    EXPECT_EQ(t["type"], "Image");
    EXPECT_EQ(t["service"][0]["id"], kBase + "/iiif/3/t");
  }
}

TEST(PresentationManifest, TheLabelIsTheImageIdUnlessTheCuratorGaveOne) {
  const tiles::Manifest m = image("boats_lake", 640, 480);
  const json plain = manifest(m);
  EXPECT_EQ(plain["label"], json::parse(R"({"none": ["boats_lake"]})"));
  for (const char* member : {"summary", "metadata", "rights", "requiredStatement"})
    EXPECT_FALSE(plain.contains(member)) << member << " without a description";

  api::Description d;
  d.label = {{"en", {"Boats"}}, {"fr", {"Bateaux"}}};
  d.summary = {{"none", {"At sunset"}}};
  d.metadata = {api::LabelledValue{{{"en", {"Place"}}}, {{"en", {"Lake"}}}}};
  d.rights = "http://creativecommons.org/licenses/by/4.0/";
  d.required_statement = api::LabelledValue{{{"none", {"Attribution"}}}, {{"none", {"Photo: A"}}}};
  const json doc = manifest(m, d);
  EXPECT_EQ(doc["label"], json::parse(R"({"en": ["Boats"], "fr": ["Bateaux"]})"));
  EXPECT_EQ(doc["summary"], json::parse(R"({"none": ["At sunset"]})"));
  EXPECT_EQ(doc["metadata"], json::parse(R"([{"label": {"en": ["Place"]}, "value": {"en": ["Lake"]}}])"));
  EXPECT_EQ(doc["rights"], "http://creativecommons.org/licenses/by/4.0/");
  EXPECT_EQ(doc["requiredStatement"],
            json::parse(R"({"label": {"none": ["Attribution"]}, "value": {"none": ["Photo: A"]}})"));
  // A description without a label still labels the manifest by the id.
  api::Description unlabelled = d;
  unlabelled.label.clear();
  EXPECT_EQ(manifest(m, unlabelled)["label"], json::parse(R"({"none": ["boats_lake"]})"));
  EXPECT_EQ(manifest(m, unlabelled)["summary"], json::parse(R"({"none": ["At sunset"]})"));
}

TEST(PresentationManifest, PartOfTheCollectionOnlyWhenListedThere) {
  const tiles::Manifest m = image("boats", 640, 480);
  const api::ManifestLinks listed = links_of("boats", true), unlisted = links_of("boats", false);
  const json in = manifest(m, {}, &listed);
  ASSERT_TRUE(in.contains("partOf"));
  EXPECT_EQ(in["partOf"], json::parse(R"([{"id": "https://tiles.example.org/iiif/presentation/3/collection",
                                          "type": "Collection"}])"));
  EXPECT_FALSE(manifest(m, {}, &unlisted).contains("partOf")) << "a private image is in no public collection";
}

// A private image's manifest names its service by a service token; every URL a viewer derives
// from the manifest must carry it as given.
TEST(PresentationManifest, TheServiceIdIsUsedAsGiven) {
  const tiles::Manifest m = image("secret", 4000, 2000);
  const std::string token = "secret~1800000000~" + std::string(64, 'a');
  const api::ManifestLinks links{kBase, kBase + "/iiif/3/" + token, false};
  const json doc = manifest(m, {}, &links);
  const json& body = painting(doc)["body"];
  EXPECT_EQ(body["id"], kBase + "/iiif/3/" + token + "/full/max/0/default.jpg");
  EXPECT_EQ(body["service"][0]["id"], kBase + "/iiif/3/" + token);
  EXPECT_EQ(doc["thumbnail"][0]["id"], kBase + "/iiif/3/" + token + "/full/250,125/0/default.jpg");
  EXPECT_EQ(doc["thumbnail"][0]["service"][0]["id"], kBase + "/iiif/3/" + token);
  // The manifest's own id and the record it links to name the image, not the token.
  EXPECT_EQ(doc["id"], kBase + "/iiif/presentation/3/secret/manifest");
  EXPECT_EQ(doc["seeAlso"][0]["id"], kBase + "/v1/images/secret");
}

TEST(PresentationPaths, AreThoseTheRouterServes) {
  EXPECT_EQ(api::manifest_path("boats"), "/iiif/presentation/3/boats/manifest");
  EXPECT_EQ(api::collection_path(), "/iiif/presentation/3/collection");
  EXPECT_EQ(api::collection_page_path(3), "/iiif/presentation/3/collection/3");
}

std::vector<std::string> page_labels(const json& collection) {
  std::vector<std::string> labels;
  for (const json& page : collection["items"]) labels.push_back(page["label"]["none"][0]);
  return labels;
}

TEST(PresentationCollection, PagesOfAHundredImages) {
  ASSERT_EQ(api::kCollectionPageSize, 100);
  const json empty = json::parse(api::collection_json(kBase, 0));
  EXPECT_EQ(empty["@context"], kContext);
  EXPECT_EQ(empty["id"], kBase + "/iiif/presentation/3/collection");
  EXPECT_EQ(empty["type"], "Collection");
  EXPECT_TRUE(empty["items"].is_array());
  EXPECT_TRUE(empty["items"].empty()) << "no images, no pages";

  EXPECT_EQ(page_labels(json::parse(api::collection_json(kBase, 1))), std::vector<std::string>{"Images 1–1 of 1"});
  EXPECT_EQ(page_labels(json::parse(api::collection_json(kBase, 100))), std::vector<std::string>{"Images 1–100 of 100"});
  const json two = json::parse(api::collection_json(kBase, 101));
  EXPECT_EQ(page_labels(two), (std::vector<std::string>{"Images 1–100 of 101", "Images 101–101 of 101"}));
  EXPECT_EQ(two["items"][0]["id"], kBase + "/iiif/presentation/3/collection/1");
  EXPECT_EQ(two["items"][1]["id"], kBase + "/iiif/presentation/3/collection/2");
  EXPECT_EQ(two["items"][1]["type"], "Collection");
  EXPECT_EQ(json::parse(api::collection_json(kBase, 250))["items"].size(), 3u);
}

TEST(PresentationCollection, APageReferencesItsImagesManifests) {
  const tiles::Manifest a = image("a", 4000, 2000), b = image("b", 300, 200);
  api::Description described;
  described.label = {{"en", {"Boats"}}};
  const json page = json::parse(api::collection_page_json(kBase, 2, 3, {{&a, described}, {&b, {}}}));
  EXPECT_EQ(page["@context"], kContext);
  EXPECT_EQ(page["id"], kBase + "/iiif/presentation/3/collection/2");
  EXPECT_EQ(page["type"], "Collection");
  EXPECT_EQ(page["label"]["none"][0], "zoomwarp images, page 2 of 3");
  EXPECT_EQ(page["partOf"][0]["id"], kBase + "/iiif/presentation/3/collection");
  ASSERT_EQ(page["items"].size(), 2u);
  const json& first = page["items"][0];
  EXPECT_EQ(first["id"], kBase + "/iiif/presentation/3/a/manifest");
  EXPECT_EQ(first["type"], "Manifest");
  EXPECT_EQ(first["label"], json::parse(R"({"en": ["Boats"]})"));
  EXPECT_EQ(first["thumbnail"][0]["id"], kBase + "/iiif/3/a/full/250,125/0/default.jpg");
  const json& second = page["items"][1];
  EXPECT_EQ(second["id"], kBase + "/iiif/presentation/3/b/manifest");
  EXPECT_EQ(second["label"], json::parse(R"({"none": ["b"]})")) << "no label given: the id";
  EXPECT_EQ(second["thumbnail"][0]["width"], 300);
  EXPECT_TRUE(json::parse(api::collection_page_json(kBase, 1, 1, {}))["items"].empty());
}

}  // namespace
}  // namespace zoomwarp
