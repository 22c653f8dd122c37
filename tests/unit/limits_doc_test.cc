// The limits of warp/core/limits.h are documented as they are enforced: api/openapi.json's schemas
// and the README's "Limits" table carry the same numbers as the constants.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "api/assets.h"
#include "tests/support/server_process.h"
#include "warp/core/limits.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
namespace limits = warp::limits;

TEST(LimitsDoc, OpenApiCarriesTheLimits) {
  const json doc = json::parse(*api::asset("openapi.json"));
  const json& schemas = doc["components"]["schemas"];
  EXPECT_EQ(schemas["Lines"]["properties"]["lines"]["maxItems"], limits::kMaxLines);
  const json& regions = schemas["SignificanceEdit"]["properties"]["regions"];
  EXPECT_EQ(regions["maxItems"], limits::kMaxRegionsPerEdit);
  EXPECT_EQ(regions["items"]["oneOf"][1]["properties"]["polygon"]["maxItems"], limits::kMaxPolygonPoints);
  for (const char* side : {"w", "h"})
    EXPECT_EQ(doc["components"]["parameters"][side]["schema"]["maximum"], limits::kMaxScreenSide) << side;
  for (const auto& [path, method] : {std::pair{"/v1/images/{id}/lines", "put"}, {"/v1/images/{id}/significance", "patch"}})
    EXPECT_TRUE(doc["paths"][path][method]["responses"].contains("413")) << path;
}

TEST(LimitsDoc, TheReadmeTableCarriesTheLimits) {
  const std::string readme = testing::read_file(testing::samples_dir() + "/../README.md");
  const auto table = readme.find("### Limits");
  ASSERT_NE(table, std::string::npos);
  const std::string section = readme.substr(table, readme.find("\n### ", table + 1) - table);
  auto row = [&](const std::string& value, const char* constant) {
    EXPECT_NE(section.find(value + " (`" + constant + "`)"), std::string::npos) << constant << " = " << value;
  };
  row(std::to_string(limits::kMaxLines), "kMaxLines");
  row(std::to_string(limits::kMaxRegionsPerEdit), "kMaxRegionsPerEdit");
  row(std::to_string(limits::kMaxPolygonPoints), "kMaxPolygonPoints");
  row(std::to_string(limits::kMaxStoredRegions), "kMaxStoredRegions");
  row("16…" + std::to_string(limits::kMaxScreenSide) + " px each", "kMaxScreenSide");
  char total[64];
  std::snprintf(total, sizeof total, "%g × the image's larger side", limits::kMaxTotalLineLength);
  row(total, "kMaxTotalLineLength");
}

}  // namespace
}  // namespace zoomwarp
