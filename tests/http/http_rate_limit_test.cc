// Upload rate limits over HTTP: past --upload-rate or --upload-bytes-per-day an upload is a 429
// with Retry-After and a JSON error, refused before its body is stored; clients without a key are
// counted by address (with --trust-forwarded-for, the address nginx appended); /metrics counts
// per key id, never per address.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;

std::string small_jpeg(const std::string& dir) {
  const std::string path = dir + "/small.jpg";
  testing::write_image(path, testing::test_pattern(64, 48, 3));
  return testing::read_file(path);
}

class RateLimit : public ::testing::Test {
 protected:
  testing::TempDir dir;
  testing::ServerProcess server{dir.path() + "/store",
                                {"--upload-rate", "2/min", "--upload-bytes-per-day", "10M", "--trust-forwarded-for", "1"}};
  HttpClient http{server.port()};
  const std::string jpg = small_jpeg(dir.path());

  testing::HttpResponse upload(const std::string& id, const std::string& forwarded_for) {
    return http.request("POST", "/v1/images?id=" + id, jpg, {{"X-Forwarded-For", forwarded_for}});
  }
};

TEST_F(RateLimit, PastTheUploadRateA429WithRetryAfter) {
  EXPECT_EQ(upload("a1", "10.0.0.1").status, 201);
  EXPECT_EQ(upload("a2", "10.0.0.1").status, 201);
  const auto refused = upload("a3", "10.0.0.1");
  EXPECT_EQ(refused.status, 429);
  const int retry_after = std::stoi(refused.header("retry-after"));
  EXPECT_GE(retry_after, 1);
  EXPECT_LE(retry_after, 30) << "2 per minute: one frees every 30 s";
  const auto body = json::parse(refused.body);
  EXPECT_EQ(body["error"]["code"], "rate_limited");
  EXPECT_EQ(http.get("/v1/images/a3").status, 404) << "nothing stored";
  EXPECT_EQ(http.get("/v1/images/a1").status, 200);
}

TEST_F(RateLimit, EachAddressHasItsOwnBudget) {
  EXPECT_EQ(upload("a1", "10.0.0.1").status, 201);
  EXPECT_EQ(upload("a2", "10.0.0.1").status, 201);
  EXPECT_EQ(upload("b1", "10.0.0.2").status, 201) << "another client address";
  // Entries before the last are the client's to invent; the last is what the proxy saw.
  EXPECT_EQ(upload("a3", "10.0.0.99, 10.0.0.1").status, 429);
  EXPECT_EQ(upload("b2", "10.0.0.1, 10.0.0.2").status, 201);
}

TEST_F(RateLimit, MetricsCountPerKeyNeverPerAddress) {
  upload("a1", "10.0.0.1");
  upload("a2", "10.0.0.1");
  upload("a3", "10.0.0.1");
  const std::string metrics = http.get("/metrics").body;
  EXPECT_NE(metrics.find("zoomwarp_uploads_total{key=\"\"} 2"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("zoomwarp_rate_limited_total{key=\"\",limit=\"uploads_per_minute\"} 1"), std::string::npos);
  EXPECT_EQ(metrics.find("10.0.0.1"), std::string::npos);
}

TEST(RateLimitBytes, PastTheDailyBytesA429) {
  testing::TempDir dir;
  const std::string jpg = small_jpeg(dir.path());
  testing::ServerProcess server{dir.path() + "/store", {"--upload-bytes-per-day", std::to_string(jpg.size() * 3 / 2)}};
  HttpClient http{server.port()};
  EXPECT_EQ(http.request("POST", "/v1/images?id=a", jpg).status, 201);
  const auto refused = http.request("POST", "/v1/images?id=b", jpg);
  EXPECT_EQ(refused.status, 429);
  EXPECT_GE(std::stol(refused.header("retry-after")), 3600) << "half an upload's bytes come back in 12 h";
  EXPECT_EQ(json::parse(refused.body)["error"]["code"], "rate_limited");
  EXPECT_NE(http.get("/metrics").body.find("zoomwarp_rate_limited_total{key=\"\",limit=\"bytes_per_day\"} 1"),
            std::string::npos);
}

TEST(RateLimitFlags, MalformedRateIsAUsageError) {
  testing::TempDir dir;
  const auto run = testing::run_command(
      {testing::zoomwarp_binary(), "serve", "--store", dir.path(), "--port", "0", "--upload-rate", "2/hour"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.output.find("--upload-rate"), std::string::npos);
}

// With keys, a key is one client wherever it comes from; /metrics (admin) counts per key id.
TEST(RateLimitKeys, PerKeyWhereverItComesFrom) {
  testing::TempDir dir;
  const std::string alice = "alice-key-AAAAAAAAAAAAAAAA", bob = "bob-key-BBBBBBBBBBBBBBBB", ops = "ops-key-OOOOOOOOOOOOOOOO";
  std::ofstream(dir.path() + "/keys") << "alice curator " << alice << "\nbob curator " << bob << "\nops admin " << ops << "\n";
  testing::ServerProcess server{dir.path() + "/store", {"--keys", dir.path() + "/keys", "--upload-rate", "1",
                                                       "--trust-forwarded-for", "1"}};
  HttpClient http{server.port()};
  const std::string jpg = small_jpeg(dir.path());
  auto upload = [&](const std::string& id, const std::string& key, const std::string& address) {
    return http.request("POST", "/v1/images?id=" + id, jpg,
                        {{"Authorization", "Bearer " + key}, {"X-Forwarded-For", address}});
  };
  EXPECT_EQ(upload("a1", alice, "10.0.0.1").status, 201);
  const auto refused = upload("a2", alice, "10.0.0.2");
  EXPECT_EQ(refused.status, 429) << "another address, the same key";
  EXPECT_GE(std::stoi(refused.header("retry-after")), 1);
  EXPECT_LE(std::stoi(refused.header("retry-after")), 60);
  EXPECT_EQ(upload("b1", bob, "10.0.0.1").status, 201) << "another key from the same address";

  const std::string metrics = http.get("/metrics", {{"Authorization", "Bearer " + ops}}).body;
  EXPECT_NE(metrics.find("zoomwarp_uploads_total{key=\"alice\"} 1"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("zoomwarp_uploads_total{key=\"bob\"} 1"), std::string::npos);
  EXPECT_NE(metrics.find("zoomwarp_rate_limited_total{key=\"alice\",limit=\"uploads_per_minute\"} 1"), std::string::npos);
  for (const std::string& secret : {alice, bob, std::string("10.0.0.")}) EXPECT_EQ(metrics.find(secret), std::string::npos);
}

}  // namespace
}  // namespace zoomwarp
