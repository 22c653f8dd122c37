// Validation of a JSON value against a schema of the OpenAPI document (api/openapi.json), for
// tests. Covers the keywords our document uses: type, enum, required, properties,
// additionalProperties, items, minItems, maxItems, minimum, maximum, oneOf, $ref (local).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace zoomwarp::testing {

// The problems found (empty: valid), each with the JSON pointer where it is.
std::vector<std::string> validate_json(const nlohmann::json& value, const nlohmann::json& schema,
                                       const nlohmann::json& document);

}  // namespace zoomwarp::testing
