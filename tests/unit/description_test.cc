// The curator's description of an image (api/description.h): what a PUT /v1/images/{id}/metadata
// body or an upload's label=, summary=, rights=, attribution= become, what is refused and with
// which status and code, and that what is stored reads back as it was given.
#include <gtest/gtest.h>

#include <functional>
#include <map>
#include <ostream>
#include <nlohmann/json.hpp>
#include <string>

#include "api/description.h"
#include "api/errors.h"

namespace zoomwarp::api {
// Failures print a description as its JSON.
void PrintTo(const Description& d, std::ostream* os) { *os << description_json(d); }
}  // namespace zoomwarp::api

namespace zoomwarp {
namespace {

using api::Description;
using api::LabelledValue;
using api::LanguageMap;
using nlohmann::json;

// The status and code parse_description refuses `body` with; {0, ""} when it takes it.
std::pair<int, std::string> refusal(const std::string& body) {
  try {
    api::parse_description(body);
  } catch (const api::ApiError& e) {
    return {e.status(), e.code()};
  }
  return {0, ""};
}

const std::pair<int, std::string> kInvalid{400, "invalid_body"};

TEST(Description, PlainStringsAreTheLanguageNone) {
  const Description d = api::parse_description(
      R"({"label": "Boats", "summary": "At sunset", "requiredStatement": {"label": "Attribution", "value": "Photo: A"},
          "metadata": [{"label": "Place", "value": "Lake"}]})");
  EXPECT_EQ(d.label, (LanguageMap{{"none", {"Boats"}}}));
  EXPECT_EQ(d.summary, (LanguageMap{{"none", {"At sunset"}}}));
  ASSERT_TRUE(d.required_statement);
  EXPECT_EQ(d.required_statement->label, (LanguageMap{{"none", {"Attribution"}}}));
  EXPECT_EQ(d.required_statement->value, (LanguageMap{{"none", {"Photo: A"}}}));
  ASSERT_EQ(d.metadata.size(), 1u);
  EXPECT_EQ(d.metadata[0].label, (LanguageMap{{"none", {"Place"}}}));
  EXPECT_EQ(d.metadata[0].value, (LanguageMap{{"none", {"Lake"}}}));
  // Written out as IIIF language maps, never as plain strings (a manifest copies them as they are).
  const json out = json::parse(api::description_json(d));
  EXPECT_EQ(out["label"], json::parse(R"({"none": ["Boats"]})"));
  EXPECT_EQ(out["summary"], json::parse(R"({"none": ["At sunset"]})"));
  EXPECT_EQ(out["metadata"], json::parse(R"([{"label": {"none": ["Place"]}, "value": {"none": ["Lake"]}}])"));
  EXPECT_EQ(out["requiredStatement"],
            json::parse(R"({"label": {"none": ["Attribution"]}, "value": {"none": ["Photo: A"]}})"));
  EXPECT_FALSE(out.contains("rights")) << "members not given are not written";
}

TEST(Description, LanguageMapsKeepEveryValueInOrder) {
  const Description d = api::parse_description(
      R"({"label": {"fr": ["Bateaux"], "en": ["Boats", "Ships"], "de-CH": ["Boote"], "none": ["#12"]}})");
  // Languages sorted, each language's values in the order given.
  EXPECT_EQ(d.label, (LanguageMap{{"de-CH", {"Boote"}}, {"en", {"Boats", "Ships"}}, {"fr", {"Bateaux"}},
                                  {"none", {"#12"}}}));
  EXPECT_EQ(json::parse(api::description_json(d))["label"]["en"], json::parse(R"(["Boats", "Ships"])"));
  EXPECT_TRUE(api::parse_description("{}").empty()) << "every member is optional";
  EXPECT_TRUE(Description{}.empty());
  EXPECT_FALSE(d.empty());
}

TEST(Description, UnknownMembersAreRefused) {
  EXPECT_EQ(refusal(R"({"title": "Boats"})"), kInvalid);
  EXPECT_EQ(refusal(R"({"label": "Boats", "Label": "Boats"})"), kInvalid) << "member names are case-sensitive";
  EXPECT_EQ(refusal(R"({"metadata": [{"label": "a", "value": "b", "lang": "en"}]})"), kInvalid);
  EXPECT_EQ(refusal(R"({"requiredStatement": {"label": "a", "value": "b", "x": 1}})"), kInvalid);
  EXPECT_EQ(refusal(R"({"metadata": [{"label": "a"}]})"), kInvalid) << "a pair needs its value";
  EXPECT_EQ(refusal(R"({"requiredStatement": {"value": "b"}})"), kInvalid) << "and its label";
}

TEST(Description, NotJsonOrNotAnObjectIsRefused) {
  for (const std::string body : {"", "label=Boats", "{\"label\": \"Boats\"", "[]", "\"Boats\"", "null", "42"}) {
    SCOPED_TRACE(body);
    EXPECT_EQ(refusal(body), kInvalid);
  }
}

TEST(Description, LanguageTagsMustBeBcp47OrNone) {
  for (const std::string tag : {"en", "EN", "en-GB", "zh-Hant-TW", "de-CH-1901", "x-klingon", "none"}) {
    SCOPED_TRACE(tag);
    const Description d = api::parse_description(R"({"label": {)" + json(tag).dump() + R"(: ["Boats"]}})");
    EXPECT_EQ(d.label, (LanguageMap{{tag, {"Boats"}}}));
  }
  for (const std::string tag : {"", "en_GB", "en-", "-en", "en--GB", "1en", "englishlanguage", "en GB", "ünï",
                                "abcdefghi", "en-abcdefghi", "None?"}) {
    SCOPED_TRACE(tag);
    EXPECT_EQ(refusal(R"({"label": {)" + json(tag).dump() + R"(: ["Boats"]}})"), kInvalid);
    EXPECT_EQ(refusal(R"({"metadata": [{"label": "a", "value": {)" + json(tag).dump() + R"(: ["b"]}}]})"), kInvalid);
  }
  // At most 35 characters: the longest tag the Presentation API's schema admits.
  const std::string long_tag = "abcdefgh-abcdefgh-abcdefgh-abcdefgh";  // 35
  ASSERT_EQ(long_tag.size(), 35u);
  EXPECT_EQ(refusal(R"({"label": {")" + long_tag + R"(": ["x"]}})"), std::make_pair(0, std::string()));
  EXPECT_EQ(refusal(R"({"label": {")" + long_tag + R"(-a": ["x"]}})"), kInvalid);
}

TEST(Description, EmptyValuesAreRefused) {
  for (const std::string body :
       {R"({"label": ""})", R"({"label": {}})", R"({"label": {"en": []}})", R"({"summary": {"en": ["a"], "fr": []}})",
        R"({"metadata": [{"label": "", "value": "b"}]})", R"({"metadata": [{"label": "a", "value": {}}]})",
        R"({"requiredStatement": {"label": "Attribution", "value": {"none": []}}})"}) {
    SCOPED_TRACE(body);
    EXPECT_EQ(refusal(body), kInvalid);
  }
  // No metadata is an empty list, which is no metadata.
  EXPECT_TRUE(api::parse_description(R"({"metadata": []})").metadata.empty());
}

TEST(Description, ValuesThatAreNotStringsAreRefused) {
  for (const std::string body :
       {R"({"label": 5})", R"({"label": null})", R"({"label": true})", R"({"label": ["Boats"]})",
        R"({"label": {"en": "Boats"}})", R"({"label": {"en": [1]}})", R"({"label": {"en": ["Boats", null]}})",
        R"({"label": {"en": [["Boats"]]}})", R"({"summary": {"en": [{"v": "a"}]}})", R"({"rights": 5})",
        R"({"rights": ["http://creativecommons.org/licenses/by/4.0/"]})", R"({"metadata": {"label": "a", "value": "b"}})",
        R"({"metadata": ["Place: Lake"]})", R"({"metadata": [{"label": "a", "value": 3}]})",
        R"({"requiredStatement": "Photo: A"})", R"({"requiredStatement": [{"label": "a", "value": "b"}]})"}) {
    SCOPED_TRACE(body);
    EXPECT_EQ(refusal(body), kInvalid);
  }
}

TEST(Description, RightsComeFromTheCreativeCommonsOrRightsStatementsVocabularies) {
  for (const std::string uri :
       {"http://creativecommons.org/licenses/by/4.0/", "http://creativecommons.org/licenses/by-nc-sa/4.0/",
        "http://creativecommons.org/publicdomain/zero/1.0/", "http://creativecommons.org/publicdomain/mark/1.0/",
        "http://rightsstatements.org/vocab/InC/1.0/", "http://rightsstatements.org/vocab/NoC-US/1.0/"}) {
    SCOPED_TRACE(uri);
    EXPECT_EQ(api::parse_description(json{{"rights", uri}}.dump()).rights, uri);
  }
  for (const std::string uri : {
           "https://creativecommons.org/licenses/by/4.0/",   // the specifications' URIs are http://
           "https://rightsstatements.org/vocab/InC/1.0/",
           "http://creativecommons.org/licenses/",           // no licence named
           "http://creativecommons.org/about/",              // not a licence or a mark
           "http://rightsstatements.org/page/InC/1.0/",      // the page, not the statement
           "http://creativecommons.org.example.com/licenses/by/4.0/",
           "http://example.org/licenses/by/4.0/",
           "creativecommons.org/licenses/by/4.0/",
           "http://creativecommons.org/licenses/by/4.0/ ",
           "http://creativecommons.org/licenses/by/4.0/?x=1",
           "CC BY 4.0",
           "",
       }) {
    SCOPED_TRACE(uri);
    EXPECT_EQ(refusal(json{{"rights", uri}}.dump()), kInvalid);
  }
  const std::string long_tail = "http://creativecommons.org/licenses/" + std::string(256, 'a');
  EXPECT_EQ(refusal(json{{"rights", long_tail}}.dump()), kInvalid) << "at most 256 characters";
}

// A body of `size` bytes: a description with a label long enough, written as description_json
// writes it, then spaces (JSON allows them after the value).
std::string description_body_of(std::size_t size) {
  Description d;
  d.label = {{"en", {""}}};
  const std::size_t overhead = api::description_json(d).size();
  EXPECT_LE(overhead + 1, size);
  const std::size_t text = size - overhead - 1;  // one byte of padding at least
  d.label = {{"en", {std::string(text, 'x')}}};
  std::string body = api::description_json(d);
  EXPECT_LE(body.size(), size);
  body.append(size - body.size(), ' ');
  return body;
}

TEST(Description, ItsSizeIsLimitedAtExactlyTheLimit) {
  const std::string at_limit = description_body_of(api::kMaxDescriptionBytes);
  ASSERT_EQ(at_limit.size(), api::kMaxDescriptionBytes);
  EXPECT_EQ(refusal(at_limit), std::make_pair(0, std::string())) << "exactly the limit is taken";
  EXPECT_EQ(refusal(at_limit + " "), std::make_pair(413, std::string("description_too_large")));
  EXPECT_EQ(refusal(std::string(api::kMaxDescriptionBytes + 1, ' ')),
            std::make_pair(413, std::string("description_too_large")))
      << "the size is checked before the body is parsed";
}

// What is stored is read back by the same parser, limits included (read_description): a body
// within the limit whose stored form (description_json, indented) is not would be answered
// 500 on every later read of the image. It is refused when it is given.
TEST(Description, AStoredFormOverTheLimitIsRefusedWhenGiven) {
  std::string many_values = "[";
  for (int i = 0; i < 30; ++i) many_values += std::string(i ? "," : "") + "\"k\"";
  many_values += "]";
  std::string compact = R"({"metadata":[)";
  for (int i = 0; i < 250; ++i) compact += std::string(i ? "," : "") + R"({"label":{"en":)" + many_values + R"(},"value":"v"})";
  compact += "]}";
  ASSERT_LE(compact.size(), api::kMaxDescriptionBytes);
  Description d;
  for (int i = 0; i < 250; ++i)
    d.metadata.push_back(LabelledValue{{{"en", std::vector<std::string>(30, "k")}}, {{"none", {"v"}}}});
  ASSERT_GT(api::description_json(d).size(), api::kMaxDescriptionBytes) << "the test's premise";
  EXPECT_EQ(refusal(compact), std::make_pair(413, std::string("description_too_large")));
  // Near the limit but within it once stored: taken, and read back the same.
  d.metadata.resize(100);
  const std::string stored = api::description_json(d);
  ASSERT_LE(stored.size(), api::kMaxDescriptionBytes);
  EXPECT_EQ(api::parse_description(stored), d);
}

TEST(Description, MetadataPairsAreLimitedAtExactlyTheLimit) {
  auto body_with = [](std::size_t n) {
    json pairs = json::array();
    for (std::size_t i = 0; i < n; ++i) pairs.push_back({{"label", "k"}, {"value", "v"}});
    return json{{"metadata", pairs}}.dump();
  };
  ASSERT_LE(body_with(api::kMaxMetadataPairs + 1).size(), api::kMaxDescriptionBytes) << "not the size limit";
  EXPECT_EQ(api::parse_description(body_with(api::kMaxMetadataPairs)).metadata.size(), api::kMaxMetadataPairs);
  EXPECT_EQ(refusal(body_with(api::kMaxMetadataPairs + 1)), std::make_pair(413, std::string("too_many_metadata")));
}

TEST(Description, ParsingWhatItWritesGivesItBack) {
  Description d;
  d.label = {{"en", {"Boats", "Ships"}}, {"fr", {"Bateaux"}}};
  d.summary = {{"none", {"A lake at sunset, \"quoted\", with a tab\tand a newline\nand ünïcødé ✓"}}};
  d.metadata = {LabelledValue{{{"en", {"Place"}}}, {{"de", {"See"}}, {"en", {"Lake"}}}},
                LabelledValue{{{"none", {"Year"}}}, {{"none", {"2024"}}}},
                LabelledValue{{{"none", {"Year"}}}, {{"none", {"2025"}}}}};  // labels may repeat
  d.rights = "http://rightsstatements.org/vocab/InC/1.0/";
  d.required_statement = LabelledValue{{{"en", {"Attribution"}}}, {{"en", {"Photo: A. Person"}}}};
  EXPECT_EQ(api::parse_description(api::description_json(d)), d);
  EXPECT_EQ(api::parse_description(api::description_json(Description{})), Description{});
  Description only_rights;
  only_rights.rights = "http://creativecommons.org/publicdomain/zero/1.0/";
  EXPECT_EQ(api::parse_description(api::description_json(only_rights)), only_rights);
  // And the equality the round trip relies on does tell descriptions apart.
  Description other = d;
  other.metadata[2].value = {{"none", {"2026"}}};
  EXPECT_FALSE(other == d);
  other = d;
  other.required_statement.reset();
  EXPECT_FALSE(other == d);
}

TEST(Description, UploadFieldsAreLaidOverTheDescriptionKeepingTheRest) {
  Description base;
  base.label = {{"en", {"Boats"}}};
  base.summary = {{"en", {"At sunset"}}};
  base.metadata = {LabelledValue{{{"none", {"Place"}}}, {{"none", {"Lake"}}}}};
  base.rights = "http://creativecommons.org/licenses/by/4.0/";
  base.required_statement = LabelledValue{{{"none", {"Attribution"}}}, {{"none", {"Photo: A"}}}};

  const Description relabelled = api::description_with_upload_fields(base, {{"label", "Ships"}});
  Description want = base;
  want.label = {{"none", {"Ships"}}};
  EXPECT_EQ(relabelled, want) << "only the label changed";

  const Description all = api::description_with_upload_fields(
      base, {{"label", "L"}, {"summary", "S"}, {"rights", "http://rightsstatements.org/vocab/NoC-US/1.0/"},
             {"attribution", "Photo: B"}});
  EXPECT_EQ(all.label, (LanguageMap{{"none", {"L"}}}));
  EXPECT_EQ(all.summary, (LanguageMap{{"none", {"S"}}}));
  EXPECT_EQ(all.rights, "http://rightsstatements.org/vocab/NoC-US/1.0/");
  ASSERT_TRUE(all.required_statement);
  EXPECT_EQ(*all.required_statement, (LabelledValue{{{"none", {"Attribution"}}}, {{"none", {"Photo: B"}}}}));
  EXPECT_EQ(all.metadata, base.metadata) << "an upload has no metadata field: the pairs stay";

  const Description fresh = api::description_with_upload_fields(Description{}, {{"summary", "S"}});
  EXPECT_TRUE(fresh.label.empty());
  EXPECT_EQ(fresh.summary, (LanguageMap{{"none", {"S"}}}));
  EXPECT_EQ(api::parse_description(api::description_json(fresh)), fresh) << "stored and read back";
}

TEST(Description, BadUploadFieldsAreRefusedAsTheQuery) {
  auto refused = [](const std::map<std::string, std::string>& fields) -> std::pair<int, std::string> {
    try {
      api::description_with_upload_fields(Description{}, fields);
    } catch (const api::ApiError& e) {
      return {e.status(), e.code()};
    }
    return {0, ""};
  };
  const std::pair<int, std::string> bad_query{400, "invalid_query"};
  EXPECT_EQ(refused({{"rights", "https://creativecommons.org/licenses/by/4.0/"}}), bad_query);
  EXPECT_EQ(refused({{"rights", "CC-BY"}}), bad_query);
  EXPECT_EQ(refused({{"label", ""}}), bad_query);
  EXPECT_EQ(refused({{"attribution", ""}}), bad_query);
  // Text that JSON cannot hold (not UTF-8) is the client's mistake, not the store's.
  EXPECT_EQ(refused({{"label", "\xff\xfe"}}), bad_query);
  EXPECT_EQ(refused({{"summary", "caf\xe9"}}), bad_query);  // Latin-1
  // Laid over a description near the limit, a long label takes the stored form over it.
  Description big;
  big.summary = {{"none", {std::string(api::kMaxDescriptionBytes - 100, 's')}}};
  ASSERT_LE(api::description_json(big).size(), api::kMaxDescriptionBytes);
  try {
    api::description_with_upload_fields(big, {{"label", std::string(200, 'l')}});
    ADD_FAILURE() << "a description over the limit was made";
  } catch (const api::ApiError& e) {
    EXPECT_EQ(e.status(), 413);
    EXPECT_EQ(e.code(), "description_too_large");
  }
}

}  // namespace
}  // namespace zoomwarp
