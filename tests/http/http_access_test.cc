// Who may write, on the wire (README "Access", api/authorize.h): every write route of the router's
// own table with no key, a wrong key, a reader key and a curator key; the admin endpoints; the
// safe default without keys and --open-writes; key rotation without a restart (the file changing,
// and SIGHUP); malformed key files at start and on reload; keys never in the log or /metrics.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <thread>

#include "api/router.h"
#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HttpClient;
using testing::HttpResponse;
using testing::ServerProcess;
using Headers = std::map<std::string, std::string>;

constexpr const char* kImage = "target";  // the image the edit routes edit

struct Keys {
  std::string reader = "reader-key-AAAAAAAAAAAAAAAA";
  std::string curator = "curator-key-BBBBBBBBBBBBBBBB";
  std::string admin = "admin-key-CCCCCCCCCCCCCCCC";
  std::string file_text() const {
    return "# test keys\nr reader " + reader + "\nc curator " + curator + "\na admin " + admin + "\n";
  }
};

Headers bearer(const std::string& key) { return {{"Authorization", "Bearer " + key}}; }

std::string error_code(const HttpResponse& r) {
  const json body = json::parse(r.body, nullptr, false);
  return body.is_object() && body.contains("error") ? body["error"].value("code", "") : "";
}

// A small image to upload: quick to ingest.
const std::string& small_png() {
  static const std::string bytes = [] {
    testing::TempDir dir;
    const std::string path = dir.path() + "/small.png";
    testing::write_image(path, testing::test_pattern(256, 192, 3), 8);
    return testing::read_file(path);
  }();
  return bytes;
}

// One request of a write route.
struct Call {
  std::string method, target, body;
  Headers headers;
};

std::string route_name(const api::Router::Route& r) { return std::string(r.method) + " " + std::string(r.path); }

// The route's path with {id} the image `id` and any other parameter "x": enough for the access
// check, which comes before the handler reads anything.
std::string instantiate(std::string_view path, const std::string& id) {
  std::string out;
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (path[i] != '{') {
      out += path[i];
      continue;
    }
    const std::size_t close = path.find('}', i);
    out += path.substr(i + 1, close - i - 1) == "id" ? id : "x";
    i = close;
  }
  return out;
}

// A request of `route` that a curator key makes succeed (2xx). `prepare` runs what it needs first
// (an image to delete), as a curator. nullopt for a write route this test does not know yet: the
// caller fails, so that a new write route gets its valid request here.
std::optional<Call> valid_call(const api::Router::Route& route, int n, const std::function<void(const Call&)>& prepare) {
  const std::string name = route_name(route);
  const std::string method(route.method);
  if (name == "POST /v1/images")
    return Call{method, "/v1/images?id=up-" + std::to_string(n), small_png(), {{"Content-Type", "image/png"}}};
  if (name == "DELETE /v1/images/{id}") {
    const std::string id = "doomed-" + std::to_string(n);
    prepare(Call{"POST", "/v1/images?id=" + id, small_png(), {{"Content-Type", "image/png"}}});
    return Call{method, "/v1/images/" + id, "", {}};
  }
  if (name == "PUT /v1/images/{id}/lines")
    return Call{method, instantiate(route.path, kImage), R"({"lines": [[10, 100, 200, 100]]})",
                {{"Content-Type", "application/json"}}};
  if (name == "PUT /v1/images/{id}/metadata")
    return Call{method, instantiate(route.path, kImage), R"({"label": "Target", "rights": "http://creativecommons.org/licenses/by/4.0/"})",
                {{"Content-Type", "application/json"}}};
  if (name == "PATCH /v1/images/{id}/significance")
    return Call{method, instantiate(route.path, kImage), R"({"regions": [{"rect": [10, 10, 50, 40], "weight": 1}]})",
                {{"Content-Type", "application/json"}}};
  return std::nullopt;
}

std::vector<api::Router::Route> write_routes() {
  std::vector<api::Router::Route> out;
  for (const auto& r : api::Router::routes())
    if (r.access != api::Access::kPublic) out.push_back(r);
  return out;
}

// A store with the image the edits edit, and a key file.
class Access : public ::testing::Test {
 protected:
  Access() {
    const std::string png = dir_.path() + "/target.png";
    std::ofstream(png, std::ios::binary) << small_png();
    const auto r = testing::run_command({testing::zoomwarp_binary(), "ingest", png, "--store", store_, "--id", kImage, "--quiet"});
    if (r.exit_code != 0) throw std::runtime_error("ingest failed: " + r.output);
    write_keys(keys_.file_text());
  }

  void write_keys(const std::string& text) { std::ofstream(keys_path_, std::ios::trunc) << text; }

  HttpResponse send(HttpClient& http, const Call& c, const Headers& extra = {}) {
    Headers h = c.headers;
    h.insert(extra.begin(), extra.end());
    return http.request(c.method, c.target, c.body, h);
  }

  std::string image_version(HttpClient& http) { return json::parse(http.get(std::string("/v1/images/") + kImage).body)["version"]; }

  testing::TempDir dir_;
  std::string store_ = dir_.path() + "/store";
  std::string keys_path_ = dir_.path() + "/keys";
  Keys keys_;
};

TEST_F(Access, EveryRouteThatChangesSomethingNeedsAKey) {
  // The loops below take their routes from here: a write route marked public would slip past them.
  for (const auto& r : api::Router::routes())
    EXPECT_TRUE(r.method == "GET" || r.access != api::Access::kPublic) << route_name(r) << " is open to anyone";
  EXPECT_GE(write_routes().size(), 4u);
}

TEST_F(Access, EveryWriteRouteNeedsACuratorKey) {
  ServerProcess server(store_, {"--keys", keys_path_});
  HttpClient http(server.port());
  int n = 0;
  for (const auto& route : write_routes()) {
    SCOPED_TRACE(route_name(route));
    const auto call = valid_call(route, n++, [&](const Call& c) {
      ASSERT_EQ(send(http, c, bearer(keys_.curator)).status / 100, 2) << "preparing " << c.target;
    });
    ASSERT_TRUE(call) << "a new write route: give it a valid request in valid_call()";
    const std::string version = image_version(http);
    const std::string list = http.get("/v1/images").body;

    const auto none = send(http, *call);
    EXPECT_EQ(none.status, 401) << none.body;
    EXPECT_EQ(none.header("www-authenticate"), "Bearer realm=\"zoomwarp\"");
    EXPECT_EQ(error_code(none), "key_required") << none.body;

    const auto wrong = send(http, *call, bearer("not-a-key-of-this-server"));
    EXPECT_EQ(wrong.status, 401) << wrong.body;
    EXPECT_EQ(wrong.header("www-authenticate"), "Bearer realm=\"zoomwarp\", error=\"invalid_token\"");
    EXPECT_EQ(error_code(wrong), "invalid_key") << wrong.body;

    const auto reader = send(http, *call, bearer(keys_.reader));
    EXPECT_EQ(reader.status, 403) << reader.body;
    EXPECT_EQ(error_code(reader), "insufficient_role") << reader.body;

    // Nothing changed by the refused requests.
    EXPECT_EQ(image_version(http), version);
    EXPECT_EQ(http.get("/v1/images").body, list);

    const auto curator = send(http, *call, bearer(keys_.curator));
    EXPECT_EQ(curator.status / 100, 2) << curator.status << " " << curator.body;
    const auto admin_call = valid_call(route, n++, [&](const Call& c) { send(http, c, bearer(keys_.admin)); });
    const auto admin = send(http, *admin_call, bearer(keys_.admin));
    EXPECT_EQ(admin.status / 100, 2) << "an admin may do what a curator may: " << admin.status << " " << admin.body;
  }
  // Reads stay open to everyone.
  EXPECT_EQ(http.get(std::string("/v1/images/") + kImage).status, 200);
  EXPECT_EQ(http.get(std::string("/dzi/") + kImage + ".dzi").status, 200);
  EXPECT_EQ(http.request("OPTIONS", "/v1/images").status, 204) << "preflight needs no key";
}

TEST_F(Access, MetricsNeedAnAdminKeyAndReadinessDetailsAreForAdmins) {
  ServerProcess server(store_, {"--keys", keys_path_});
  HttpClient http(server.port());
  const auto none = http.get("/metrics");
  EXPECT_EQ(none.status, 401);
  EXPECT_EQ(none.header("www-authenticate"), "Bearer realm=\"zoomwarp\"");
  EXPECT_EQ(http.get("/metrics", bearer("not-a-key-of-this-server")).status, 401);
  EXPECT_EQ(http.get("/metrics", bearer(keys_.reader)).status, 403);
  EXPECT_EQ(http.get("/metrics", bearer(keys_.curator)).status, 403);
  const auto admin = http.get("/metrics", bearer(keys_.admin));
  EXPECT_EQ(admin.status, 200);
  EXPECT_NE(admin.body.find("zoomwarp_images"), std::string::npos);

  const auto probe = http.get("/readyz");
  EXPECT_EQ(probe.status, 200) << "probes send no key";
  EXPECT_EQ(json::parse(probe.body)["status"], "ready");
  EXPECT_FALSE(json::parse(probe.body).contains("checks")) << probe.body;
  EXPECT_FALSE(json::parse(http.get("/readyz", bearer(keys_.curator)).body).contains("checks"));
  const json details = json::parse(http.get("/readyz", bearer(keys_.admin)).body);
  EXPECT_EQ(details["checks"]["store"], "ok") << details;
}

TEST_F(Access, WithoutKeysWritesAreRefusedUnlessOpenWrites) {
  {
    ServerProcess server(store_, {}, ServerProcess::Writes::kAsConfigured);
    HttpClient http(server.port());
    int n = 0;
    for (const auto& route : write_routes()) {
      SCOPED_TRACE(route_name(route));
      const auto call = valid_call(route, n++, [](const Call&) {});  // nothing can be prepared
      ASSERT_TRUE(call);
      const auto r = send(http, *call, bearer(keys_.curator));
      EXPECT_EQ(r.status, 403) << r.body;
      EXPECT_EQ(error_code(r), "writes_disabled") << r.body;
      EXPECT_NE(r.body.find("--keys"), std::string::npos) << r.body;
      EXPECT_NE(r.body.find("--open-writes"), std::string::npos) << r.body;
    }
    EXPECT_EQ(http.get("/metrics").status, 200) << "without keys, as before keys existed";
    EXPECT_TRUE(json::parse(http.get("/readyz").body).contains("checks"));
  }
  ServerProcess server(store_, {"--open-writes"}, ServerProcess::Writes::kAsConfigured);
  EXPECT_NE(server.log().find(R"("level":"warn","msg":"open writes)"), std::string::npos) << server.log();
  HttpClient http(server.port());
  int n = 100;
  for (const auto& route : write_routes()) {
    SCOPED_TRACE(route_name(route));
    const auto call = valid_call(route, n++, [&](const Call& c) { ASSERT_EQ(send(http, c).status / 100, 2); });
    const auto r = send(http, *call);
    EXPECT_EQ(r.status / 100, 2) << r.status << " " << r.body;
  }
}

TEST_F(Access, KeysAndOpenWritesExcludeEachOther) {
  const auto r = testing::run_command({"/usr/bin/timeout", "20", testing::zoomwarp_binary(), "serve", "--host", "127.0.0.1",
                                       "--port", "0", "--store", store_, "--keys", keys_path_, "--open-writes"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("exclude each other"), std::string::npos) << r.output;
}

TEST_F(Access, AMalformedKeyFileStopsTheStart) {
  write_keys("c curator " + keys_.curator + "\nbroken line\n");
  const auto r = testing::run_command({"/usr/bin/timeout", "20", testing::zoomwarp_binary(), "serve", "--host", "127.0.0.1",
                                       "--port", "0", "--store", store_, "--keys", keys_path_});
  EXPECT_EQ(r.exit_code, 1) << r.output;  // not 124: it did not start serving
  EXPECT_NE(r.output.find("line 2: expected KEY_ID ROLE KEY"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find(keys_.curator), std::string::npos) << "the key in the message";
}

// Polls (the key file is looked at at most once a second) until `done` or 20 s.
bool eventually(const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return done();
}

TEST_F(Access, RotationWithoutRestart) {
  ServerProcess server(store_, {"--keys", keys_path_, "--log-requests", "1"});
  HttpClient http(server.port());
  auto status = [&](const std::string& key) { return http.get("/metrics", bearer(key)).status; };
  ASSERT_EQ(status(keys_.admin), 200);

  // 1. The file is rewritten: the server notices by itself.
  const std::string rotated = "admin-key-DDDDDDDDDDDDDDDD-rotated";
  write_keys("a admin " + rotated + "\n");
  EXPECT_TRUE(eventually([&] { return status(keys_.admin) == 401; })) << "the old key still works";
  EXPECT_EQ(status(rotated), 200);

  // 2. SIGHUP: a rewrite the file's stamp does not show (same size, inode and mtime) is read too.
  struct stat before {};
  ASSERT_EQ(::stat(keys_path_.c_str(), &before), 0);
  const std::string again = "admin-key-EEEEEEEEEEEEEEEE-rotated";
  ASSERT_EQ(again.size(), rotated.size());
  {
    std::fstream f(keys_path_, std::ios::in | std::ios::out);  // in place: same inode
    f << "a admin " + again + "\n";
  }
  const timespec times[2] = {before.st_atim, before.st_mtim};
  ASSERT_EQ(::utimensat(AT_FDCWD, keys_path_.c_str(), times, 0), 0);
  ASSERT_EQ(::kill(server.pid(), SIGHUP), 0);
  EXPECT_TRUE(eventually([&] { return status(again) == 200; })) << "SIGHUP did not reload the keys";
  EXPECT_EQ(status(rotated), 401);

  // 3. A malformed rewrite: the keys in force stay, and the log says why. (The file is looked at
  // on requests: each poll makes one, and it must keep working.)
  write_keys("a admin " + again + "\nb root short\n");
  EXPECT_TRUE(eventually([&] {
    EXPECT_EQ(status(again), 200);
    return server.log().find("was not reloaded") != std::string::npos;
  })) << server.log();
  EXPECT_NE(server.log().find(R"("level":"error")"), std::string::npos);

  // The keys appear nowhere: not in the log (requests are logged), not in the metrics.
  const std::string metrics = http.get("/metrics", bearer(again)).body;
  for (const std::string& key : {keys_.reader, keys_.curator, keys_.admin, rotated, again}) {
    EXPECT_EQ(server.log().find(key), std::string::npos) << "a key in the log";
    EXPECT_EQ(metrics.find(key), std::string::npos) << "a key in /metrics";
  }
  EXPECT_EQ(server.terminate(), 0) << "SIGHUP must not have ended or upset the server";
}

}  // namespace
}  // namespace zoomwarp
