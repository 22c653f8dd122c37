// api/openapi.json and the router's route table describe the same API: every route the router
// serves is documented, and every documented path is a route (or one of the server's operations
// endpoints, which tests/http probes on a running server).
#include <gtest/gtest.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <set>

#include "api/assets.h"
#include "api/router.h"

namespace zoomwarp {
namespace {

using nlohmann::json;

TEST(OpenApi, DocumentsExactlyTheRoutesServed) {
  const json doc = json::parse(*api::asset("openapi.json"));
  ASSERT_EQ(doc["openapi"], "3.1.0");
  std::set<std::pair<std::string, std::string>> documented, served;
  for (const auto& [path, item] : doc["paths"].items())
    for (const auto& [method, op] : item.items())
      if (method != "parameters") {
        std::string m = method;
        for (char& c : m) c = char(std::toupper(static_cast<unsigned char>(c)));
        documented.emplace(m, path);
      }
  for (const auto& r : api::Router::routes()) served.emplace(std::string(r.method), std::string(r.path));
  for (const auto& r : served) EXPECT_TRUE(documented.count(r)) << r.first << " " << r.second << " is served but not documented";
  const std::set<std::string> operations = {"/healthz", "/readyz", "/metrics"};  // server/ops.cc
  for (const auto& d : documented)
    EXPECT_TRUE(served.count(d) || (d.first == "GET" && operations.count(d.second)))
        << d.first << " " << d.second << " is documented but not served";
}

TEST(OpenApi, EveryReferenceResolvesAndEveryOperationHasAnId) {
  const json doc = json::parse(*api::asset("openapi.json"));
  std::set<std::string> ids;
  std::function<void(const json&)> walk = [&](const json& j) {
    if (j.is_object()) {
      if (j.contains("$ref")) {
        const std::string ref = j["$ref"];
        ASSERT_EQ(ref.rfind("#/", 0), 0u) << ref;
        EXPECT_NO_THROW(doc.at(json::json_pointer(ref.substr(1)))) << ref << " does not resolve";
      }
      for (const auto& [k, v] : j.items()) walk(v);
    } else if (j.is_array()) {
      for (const auto& v : j) walk(v);
    }
  };
  walk(doc);
  for (const auto& [path, item] : doc["paths"].items())
    for (const auto& [method, op] : item.items())
      if (method != "parameters") {
        ASSERT_TRUE(op.contains("operationId")) << method << " " << path;
        EXPECT_TRUE(ids.insert(op["operationId"].get<std::string>()).second) << "duplicate operationId";
        EXPECT_TRUE(op.contains("responses")) << method << " " << path;
      }
}

}  // namespace
}  // namespace zoomwarp
