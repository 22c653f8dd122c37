// The web viewer (web/, embedded in the binary): the page at "/", and every module it imports,
// directly or not, served with the content type browsers insist on for module scripts — a file
// left out of the embedded list in api/CMakeLists.txt fails here. The JSON index lives at "/v1".
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <regex>
#include <set>
#include <string>
#include <vector>

#include "tests/support/http_client.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using testing::HttpClient;

// The "/name.js" of each `import … from './name.js'` in a module.
std::vector<std::string> imports(const std::string& module) {
  static const std::regex from(R"(from '\./([A-Za-z0-9_-]+\.js)')");
  std::vector<std::string> out;
  for (std::sregex_iterator it(module.begin(), module.end(), from), end; it != end; ++it) out.push_back("/" + (*it)[1].str());
  return out;
}

TEST(Web, ServesThePageEveryModuleItImportsAndTheIndex) {
  testing::TempDir dir;
  testing::ServerProcess server(dir.path() + "/store");
  HttpClient http(server.port());

  const auto page = http.get("/");
  ASSERT_EQ(page.status, 200);
  EXPECT_EQ(page.header("content-type"), "text/html; charset=utf-8");
  EXPECT_EQ(page.header("cache-control"), "no-cache");
  EXPECT_NE(page.body.find(R"(<script type="module" src="/viewer.js">)"), std::string::npos);
  EXPECT_NE(page.body.find(R"(href="/viewer.css")"), std::string::npos);

  const auto style = http.get("/viewer.css");
  EXPECT_EQ(style.status, 200);
  EXPECT_EQ(style.header("content-type"), "text/css; charset=utf-8");

  std::vector<std::string> pending = {"/viewer.js"};
  std::set<std::string> served;
  while (!pending.empty()) {
    const std::string path = pending.back();
    pending.pop_back();
    if (!served.insert(path).second) continue;
    const auto script = http.get(path);
    ASSERT_EQ(script.status, 200) << path;
    EXPECT_EQ(script.header("content-type"), "text/javascript; charset=utf-8") << path;
    EXPECT_EQ(script.header("cache-control"), "no-cache") << path;
    for (const std::string& next : imports(script.body)) pending.push_back(next);
  }
  EXPECT_GT(served.size(), 1u) << "viewer.js imports its modules";

  const auto missing = http.get("/no-such-module.js");
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(nlohmann::json::parse(missing.body)["error"]["code"], "file_not_found");
  EXPECT_EQ(http.request("POST", "/viewer.js", "").status, 405);

  // The JSON index moved to /v1.
  const auto index = http.get("/v1");
  ASSERT_EQ(index.status, 200);
  EXPECT_EQ(index.header("content-type"), "application/json");
  const auto links = nlohmann::json::parse(index.body)["links"];
  EXPECT_EQ(links["viewer"], "/");
  EXPECT_EQ(links["images"], "/v1/images");
}

}  // namespace
}  // namespace zoomwarp
