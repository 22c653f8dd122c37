// Issue 42's garbage-collection scenario, with three `zoomwarp serve` processes on one store — a
// folder, and a bucket (OpenStack Swift's s3api on loopback, tests/support/swift_s3.h): replica A
// reads an image's version and trusts it for --store-recheck-ms; the image, older than
// --gc-grace by then, is re-uploaded on replica B; replica C starts, and collects garbage as every
// replica does at start. Every read on A during the grace is 200 (the superseded version was
// removed by C before: its age counted from its creation, and A answered 500 for every tile it
// had not cached). Once the grace has passed, a collection removes it. And serve refuses a grace
// shorter than the recheck window.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <thread>

#include "tests/support/http_client.h"
#include "tests/support/server_process.h"
#include "tests/support/swift_s3.h"
#include "tiles/s3_client.h"
#include "tiles/s3_config.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using testing::HttpClient;
using testing::ServerProcess;
using testing::TempDir;

constexpr int kGraceSeconds = 3;  // --gc-grace, and --store-recheck-ms as long

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

const std::string& portrait() {
  static const std::string bytes = testing::read_file(testing::samples_dir() + "/astronaut_portrait.png");
  return bytes;
}

// A region of the 512×512 image no earlier request asked for: read from the version's level file,
// not from a cache.
std::string fresh_region(int k) {
  return "/iiif/3/x/" + std::to_string(7 * k % 440) + "," + std::to_string(13 * k % 440) + ",64,64/64,/0/default.jpg";
}

class GcGrace : public ::testing::Test {
 protected:
  // The store (a folder, or s3://…) and each replica's own flags.
  virtual std::string store() = 0;
  virtual std::vector<std::string> own_flags(const TempDir&) { return {}; }
  // How many versions of image x the store holds.
  virtual int versions_of_x() = 0;

  std::unique_ptr<ServerProcess> replica(const TempDir& dir) {
    std::vector<std::string> flags = own_flags(dir);
    for (const std::string& f : {std::string("--gc-grace"), std::to_string(kGraceSeconds), std::string("--store-recheck-ms"),
                                 std::to_string(kGraceSeconds * 1000)})
      flags.push_back(f);
    return std::make_unique<ServerProcess>(store(), flags);
  }

  void run_scenario() {
    TempDir a_dir, b_dir, c_dir, d_dir;
    auto a = replica(a_dir), b = replica(b_dir);
    HttpClient on_a(a->port()), on_b(b->port());
    ASSERT_EQ(on_a.request("POST", "/v1/images?id=x", portrait()).status, 201);
    // Older than the grace by the time it is replaced.
    std::this_thread::sleep_for(std::chrono::milliseconds(kGraceSeconds * 1000 + 300));
    ASSERT_EQ(on_a.get("/v1/images/x").status, 200);  // A trusts this version from now on
    const auto trusted_from = Clock::now();
    ASSERT_EQ(on_a.get(fresh_region(0)).status, 200);
    ASSERT_EQ(on_b.request("POST", "/v1/images?id=x", portrait()).status, 201) << "re-uploaded on B";
    EXPECT_EQ(versions_of_x(), 2);
    auto c = replica(c_dir);  // collects garbage at start
    // Every read on A until past the grace: A serves the version it trusts, then the new one.
    std::map<int, int> statuses;
    int k = 1;
    while (seconds_since(trusted_from) < kGraceSeconds + 1) {
      const auto r = on_a.get(fresh_region(k++));
      ++statuses[r.status];
      EXPECT_EQ(r.status, 200) << "read " << k << " on A, " << seconds_since(trusted_from) << " s after it read the version: "
                               << r.body;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    // The loop ran through the grace whatever each read took; a few reads are enough to have
    // sampled it (under a loaded machine a read from the bucket can take a few hundred ms).
    EXPECT_GT(k, 5) << "reads made during the grace";
    // Past the grace, the next collection (another replica's start) removes the replaced version.
    EXPECT_EQ(versions_of_x(), 2) << "kept through the grace";
    auto d = replica(d_dir);
    EXPECT_EQ(versions_of_x(), 1) << "removed once the grace has passed";
    EXPECT_EQ(on_a.get(fresh_region(k)).status, 200);
  }
};

class GcGraceFolder : public GcGrace {
 protected:
  std::string store() override { return dir_.path(); }
  int versions_of_x() override {
    int n = 0;
    for (const auto& e : fs::directory_iterator(dir_.path() + "/versions"))
      n += e.path().filename().string().starts_with("x@");
    return n;
  }
  TempDir dir_;
};

class GcGraceBucket : public GcGrace {
 protected:
  void SetUp() override {
    test::SwiftS3& s3 = test::SwiftS3::shared();
    for (const auto& [k, v] : s3.environment()) ::setenv(k.c_str(), v.c_str(), 1);
    bucket_ = s3.new_bucket("gc");
  }
  std::string store() override { return "s3://" + bucket_ + "/museum"; }
  std::vector<std::string> own_flags(const TempDir& dir) override { return {"--store-cache", dir.path()}; }
  int versions_of_x() override {
    tiles::S3Client client(tiles::S3Config::from_environment());
    const auto page = client.list(bucket_, "museum/versions/", "/", "", Clock::now() + std::chrono::seconds(10));
    int n = 0;
    for (const std::string& p : page.common_prefixes) n += p.starts_with("museum/versions/x@");
    return n;
  }
  std::string bucket_;
};

TEST_F(GcGraceFolder, EveryReadOnATrustingReplicaIsAnsweredDuringTheGrace) { run_scenario(); }

TEST_F(GcGraceBucket, EveryReadOnATrustingReplicaIsAnsweredDuringTheGrace) { run_scenario(); }

// A grace shorter than the window replicas trust a version for is refused at start, with the
// reason, exit code 2.
TEST(GcGraceConfig, AGraceShorterThanTheRecheckWindowIsRefused) {
  TempDir store;
  try {
    ServerProcess refused(store.path(), {"--gc-grace", "30", "--store-recheck-ms", "120000"});
    ADD_FAILURE() << "started";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--gc-grace (30 s) must be at least --store-recheck-ms (120000 ms)"), std::string::npos) << what;
  }
  ServerProcess fine(store.path(), {"--gc-grace", "120", "--store-recheck-ms", "120000"});
  EXPECT_EQ(HttpClient(fine.port()).get("/healthz").status, 200);
}

}  // namespace
}  // namespace zoomwarp
