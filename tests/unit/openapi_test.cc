// api/openapi.json and the router's route table describe the same API: every route the router
// serves is documented, and every documented path is a route (or one of the server's operations
// endpoints, which tests/http probes on a running server).
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <optional>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <string_view>

#include "api/assets.h"
#include "api/router.h"
#include "warp/methods/retargeting_method.h"

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

// The access an operation's `security` declares: none (public), or the least bearer role
// (api/authorize.h); an operation that may also be called without a key ({} among its
// alternatives, /readyz) is public.
api::Access declared_access(const json& op) {
  if (!op.contains("security")) return api::Access::kPublic;
  std::optional<api::Access> least;
  for (const auto& requirement : op["security"]) {
    if (requirement.empty()) return api::Access::kPublic;
    const json& roles = requirement.at("bearer");
    EXPECT_EQ(roles.size(), 1u) << requirement;
    const api::Access a = roles.at(0) == "admin" ? api::Access::kAdmin : api::Access::kCurator;
    EXPECT_TRUE(roles.at(0) == "admin" || roles.at(0) == "curator") << requirement;
    if (!least || a < *least) least = a;
  }
  return *least;
}

TEST(OpenApi, EachRoutesSecurityIsTheAccessTheRouterChecks) {
  const json doc = json::parse(*api::asset("openapi.json"));
  ASSERT_TRUE(doc["components"]["securitySchemes"].contains("bearer"));
  EXPECT_EQ(doc["components"]["securitySchemes"]["bearer"]["scheme"], "bearer");
  int restricted = 0;
  for (const auto& r : api::Router::routes()) {
    std::string method(r.method);
    for (char& c : method) c = char(std::tolower(static_cast<unsigned char>(c)));
    const json& op = doc["paths"][std::string(r.path)][method];
    EXPECT_EQ(declared_access(op), r.access) << r.method << " " << r.path;
    if (r.access != api::Access::kPublic) {
      ++restricted;
      EXPECT_TRUE(op["responses"].contains("401") && op["responses"].contains("403")) << r.method << " " << r.path;
    }
  }
  EXPECT_GE(restricted, 4) << "the write routes";
  // Reads of one image may be of a private one: they declare the curator key and the signed URL
  // (api/url_signing.h) as their alternatives to no credentials.
  ASSERT_TRUE(doc["components"]["securitySchemes"].contains("signedUrl"));
  EXPECT_EQ(doc["components"]["securitySchemes"]["signedUrl"]["in"], "query");
  int image_reads = 0;
  for (const auto& r : api::Router::routes()) {
    if (r.method != "GET" || std::string_view(r.path).find("{id}") == std::string_view::npos) continue;
    ++image_reads;
    const json& security = doc["paths"][std::string(r.path)]["get"]["security"];
    EXPECT_NE(std::find(security.begin(), security.end(), json::parse(R"({"bearer": ["curator"]})")), security.end()) << r.path;
    EXPECT_NE(std::find(security.begin(), security.end(), json::parse(R"({"signedUrl": []})")), security.end()) << r.path;
  }
  EXPECT_GE(image_reads, 10);
  // The server's operations endpoints (server/ops.cc): /metrics is admin, /readyz open to probes.
  EXPECT_EQ(declared_access(doc["paths"]["/metrics"]["get"]), api::Access::kAdmin);
  EXPECT_EQ(declared_access(doc["paths"]["/readyz"]["get"]), api::Access::kPublic);
  EXPECT_EQ(declared_access(doc["paths"]["/healthz"]["get"]), api::Access::kPublic);
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


// `method=` offers the ICAZ operator's three and every registered retargeting method, and /mesh
// declares the 501 that a method without a mesh answers.
TEST(OpenApi, MethodEnumIsTheRegistry) {
  const json doc = json::parse(*api::asset("openapi.json"));
  std::set<std::string> want = {"icaz", "traditional", "retarget-zoom"};
  bool meshless = false;
  for (const warp::RetargetingMethod* m : warp::retargeting_methods()) {
    want.emplace(m->name);
    meshless |= !m->has_mesh;
  }
  const json& values = doc["components"]["parameters"]["method"]["schema"]["enum"];
  EXPECT_EQ(std::set<std::string>(values.begin(), values.end()), want);
  EXPECT_TRUE(!meshless || doc["paths"]["/v1/images/{id}/mesh"]["get"]["responses"].contains("501"));
}

}  // namespace
}  // namespace zoomwarp
