#include "tests/support/json_schema.h"

namespace zoomwarp::testing {

namespace {

using nlohmann::json;

bool has_type(const json& v, const std::string& type) {
  if (type == "object") return v.is_object();
  if (type == "array") return v.is_array();
  if (type == "string") return v.is_string();
  if (type == "integer") return v.is_number_integer() || (v.is_number_float() && v.get<double>() == std::floor(v.get<double>()));
  if (type == "number") return v.is_number();
  if (type == "boolean") return v.is_boolean();
  if (type == "null") return v.is_null();
  return false;
}

void check(const json& v, const json& schema, const json& doc, const std::string& at, std::vector<std::string>& out) {
  if (schema.contains("$ref")) {
    const std::string ref = schema["$ref"];
    return check(v, doc.at(json::json_pointer(ref.substr(1))), doc, at, out);
  }
  auto fail = [&](const std::string& what) { out.push_back((at.empty() ? "/" : at) + ": " + what); };
  if (schema.contains("type") && !has_type(v, schema["type"])) return fail("not of type " + schema["type"].get<std::string>());
  if (schema.contains("enum") && std::find(schema["enum"].begin(), schema["enum"].end(), v) == schema["enum"].end())
    fail("not one of " + schema["enum"].dump());
  if (v.is_number()) {
    if (schema.contains("minimum") && v.get<double>() < schema["minimum"].get<double>()) fail("below minimum");
    if (schema.contains("maximum") && v.get<double>() > schema["maximum"].get<double>()) fail("above maximum");
  }
  if (v.is_object()) {
    for (const auto& name : schema.value("required", json::array()))
      if (!v.contains(name.get<std::string>())) fail("missing " + name.get<std::string>());
    const json props = schema.value("properties", json::object());
    for (const auto& [k, item] : v.items()) {
      if (props.contains(k)) check(item, props[k], doc, at + "/" + k, out);
      else if (schema.contains("additionalProperties") && schema["additionalProperties"] == false) fail("unexpected " + k);
    }
  }
  if (v.is_array()) {
    if (schema.contains("minItems") && v.size() < schema["minItems"].get<std::size_t>()) fail("too few items");
    if (schema.contains("maxItems") && v.size() > schema["maxItems"].get<std::size_t>()) fail("too many items");
    if (schema.contains("items"))
      for (std::size_t i = 0; i < v.size(); ++i) check(v[i], schema["items"], doc, at + "/" + std::to_string(i), out);
  }
  if (schema.contains("oneOf")) {
    int matches = 0;
    for (const auto& alternative : schema["oneOf"]) {
      std::vector<std::string> problems;
      check(v, alternative, doc, at, problems);
      matches += problems.empty();
    }
    if (matches != 1) fail("matches " + std::to_string(matches) + " of oneOf, not exactly 1");
  }
}

}  // namespace

std::vector<std::string> validate_json(const json& value, const json& schema, const json& document) {
  std::vector<std::string> out;
  check(value, schema, document, "", out);
  return out;
}

}  // namespace zoomwarp::testing
