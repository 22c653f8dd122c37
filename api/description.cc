#include "api/description.h"

#include <regex>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "api/errors.h"

namespace zoomwarp::api {

namespace {

using nlohmann::json;

[[noreturn]] void invalid(const std::string& message) { throw ApiError(400, "invalid_body", message); }

// BCP 47 in the shape the Presentation API's schema checks, plus "none" (§3.1, "Language of
// Property Values").
bool is_language_tag(const std::string& s) {
  static const std::regex tag("[A-Za-z]{1,8}(-[A-Za-z0-9]{1,8})*");
  return s == "none" || (s.size() <= 35 && std::regex_match(s, tag));
}

LanguageMap language_map(const json& v, const std::string& where) {
  if (v.is_string()) {
    if (v.get<std::string>().empty()) invalid(where + " is empty");
    return {{"none", {v.get<std::string>()}}};
  }
  if (!v.is_object() || v.empty())
    invalid(where + " must be a string or a language map such as {\"en\": [\"…\"]}");
  LanguageMap map;
  for (const auto& [language, values] : v.items()) {
    if (!is_language_tag(language)) invalid(where + ": '" + language + "' is not a BCP 47 language tag or \"none\"");
    if (!values.is_array() || values.empty())
      invalid(where + "." + language + " must be a non-empty array of strings");
    std::vector<std::string> texts;
    for (const json& t : values) {
      if (!t.is_string()) invalid(where + "." + language + " must hold strings only");
      texts.push_back(t.get<std::string>());
    }
    map.emplace_back(language, std::move(texts));
  }
  return map;
}

LabelledValue labelled_value(const json& v, const std::string& where) {
  if (!v.is_object()) invalid(where + " must be an object {\"label\", \"value\"}");
  for (const auto& [k, _] : v.items())
    if (k != "label" && k != "value") invalid(where + " has an unknown member '" + k + "' (label and value only)");
  if (!v.contains("label") || !v.contains("value")) invalid(where + " needs both label and value");
  return {language_map(v["label"], where + ".label"), language_map(v["value"], where + ".value")};
}

// The schema of the Presentation API admits Creative Commons licences and public-domain marks and
// RightsStatements.org statements, by their http URIs (§3.3.3 "rights").
void check_rights(const std::string& uri) {
  static const std::regex allowed(
      "http://(creativecommons\\.org/(licenses|publicdomain)|rightsstatements\\.org/vocab)/[A-Za-z0-9._~/-]+");
  if (uri.size() > 256 || !std::regex_match(uri, allowed))
    invalid("rights must be a Creative Commons URI (http://creativecommons.org/licenses/… or …/publicdomain/…) "
            "or a RightsStatements.org URI (http://rightsstatements.org/vocab/…), with http:// as those "
            "specifications define them; not '" + uri.substr(0, 256) + "'");
}

json map_json(const LanguageMap& m) {
  json j = json::object();
  for (const auto& [language, values] : m) j[language] = values;
  return j;
}

json labelled_json(const LabelledValue& v) { return {{"label", map_json(v.label)}, {"value", map_json(v.value)}}; }

}  // namespace

Description parse_description(std::string_view body) {
  if (body.size() > kMaxDescriptionBytes)
    throw ApiError(413, "description_too_large",
                   "a description is at most " + std::to_string(kMaxDescriptionBytes) + " bytes of JSON");
  json j;
  try {
    j = json::parse(body);
  } catch (const json::parse_error& e) {
    invalid(std::string("the body is not JSON: ") + e.what());
  }
  if (!j.is_object()) invalid("the body must be a JSON object");
  Description d;
  for (const auto& [k, v] : j.items()) {
    if (k == "label") d.label = language_map(v, "label");
    else if (k == "summary") d.summary = language_map(v, "summary");
    else if (k == "rights") {
      if (!v.is_string()) invalid("rights must be a string (a URI)");
      check_rights(v.get<std::string>());
      d.rights = v.get<std::string>();
    } else if (k == "requiredStatement") d.required_statement = labelled_value(v, "requiredStatement");
    else if (k == "metadata") {
      if (!v.is_array()) invalid("metadata must be an array of {\"label\", \"value\"}");
      if (v.size() > kMaxMetadataPairs)
        throw ApiError(413, "too_many_metadata",
                       "at most " + std::to_string(kMaxMetadataPairs) + " metadata pairs, not " + std::to_string(v.size()));
      for (std::size_t i = 0; i < v.size(); ++i)
        d.metadata.push_back(labelled_value(v[i], "metadata[" + std::to_string(i) + "]"));
    } else {
      invalid("unknown member '" + k + "' (label, summary, metadata, rights and requiredStatement are taken)");
    }
  }
  // The limit holds for what is stored too (description_json, indented, which read_description
  // parses again): a compact body within it could otherwise be stored over it, and every later
  // read of the image would fail.
  if (description_json(d).size() > kMaxDescriptionBytes)
    throw ApiError(413, "description_too_large",
                   "a description is at most " + std::to_string(kMaxDescriptionBytes) +
                       " bytes of JSON as stored (indented, as GET /v1/images/{id}/metadata answers it)");
  return d;
}

std::string description_json(const Description& d) {
  json j = json::object();
  if (!d.label.empty()) j["label"] = map_json(d.label);
  if (!d.summary.empty()) j["summary"] = map_json(d.summary);
  if (!d.metadata.empty()) {
    json pairs = json::array();
    for (const LabelledValue& v : d.metadata) pairs.push_back(labelled_json(v));
    j["metadata"] = pairs;
  }
  if (!d.rights.empty()) j["rights"] = d.rights;
  if (d.required_statement) j["requiredStatement"] = labelled_json(*d.required_statement);
  return j.dump(2) + "\n";
}

Description description_with_upload_fields(Description d, const std::map<std::string, std::string>& fields) {
  for (const auto& [name, value] : fields) {
    if (value.empty()) throw ApiError(400, "invalid_query", name + "= is empty");
    // Percent-decoding gives any bytes; JSON text is UTF-8 (description_json would throw later).
    try {
      (void)json(value).dump();
    } catch (const json::type_error&) {
      throw ApiError(400, "invalid_query", name + "= is not UTF-8 text");
    }
    if (name == "label") d.label = {{"none", {value}}};
    else if (name == "summary") d.summary = {{"none", {value}}};
    else if (name == "rights") {
      try {
        check_rights(value);
      } catch (const ApiError& e) {
        throw ApiError(400, "invalid_query", e.what());
      }
      d.rights = value;
    } else if (name == "attribution") d.required_statement = LabelledValue{{{"none", {"Attribution"}}}, {{"none", {value}}}};
    else throw std::logic_error("not an upload description field: " + name);
  }
  if (description_json(d).size() > kMaxDescriptionBytes)
    throw ApiError(413, "description_too_large",
                   "with these fields the image's description would be over " + std::to_string(kMaxDescriptionBytes) +
                       " bytes of JSON");
  return d;
}

std::function<void(const tiles::ImageEntry*, const tiles::VersionFiles&)> carry_description(
    std::map<std::string, std::string> fields) {
  return [fields = std::move(fields)](const tiles::ImageEntry* published, const tiles::VersionFiles& staged) {
    if (fields.empty()) {
      if (!published) return;
      if (const auto bytes = published->files->read(kDescriptionFile)) staged.write(kDescriptionFile, *bytes);
      return;
    }
    const Description d = description_with_upload_fields(published ? read_description(*published) : Description{}, fields);
    staged.write(kDescriptionFile, description_json(d));
  };
}

Description read_description(const tiles::ImageEntry& image) {
  const auto bytes = image.files->read(kDescriptionFile);
  if (!bytes) return {};
  try {
    return parse_description(*bytes);
  } catch (const ApiError& e) {
    throw std::runtime_error(image.files->location() + "/" + kDescriptionFile + " is damaged: " + e.what());
  }
}

std::shared_ptr<const tiles::ImageEntry> publish_description(tiles::Store& store, const tiles::ImageEntry& current,
                                                             const Description& d) {
  // Every other file of the version as hard links (pyramid, analyses, the curator's warp.json).
  const std::string staging = store.make_staging_copy(current);
  try {
    tiles::folder_files(staging)->write(kDescriptionFile, description_json(d));
  } catch (...) {
    store.discard(staging);
    throw;
  }
  return store.publish(staging, current.manifest, &current.manifest.version);
}

bool operator==(const LabelledValue& a, const LabelledValue& b) { return a.label == b.label && a.value == b.value; }

bool operator==(const Description& a, const Description& b) {
  return a.label == b.label && a.summary == b.summary && a.metadata == b.metadata && a.rights == b.rights &&
         a.required_statement == b.required_statement;
}

}  // namespace zoomwarp::api
