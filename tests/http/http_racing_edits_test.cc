// Issue 42's lost edits: two `zoomwarp serve` replicas on one store — a bucket (OpenStack
// Swift's s3api on loopback, tests/support/swift_s3.h, which has no conditional writes) and a
// folder — each take an edit of one image made against the same ETag, at the same moment, for
// 100 rounds. In every round exactly one is taken (200) and the other's client is told (409 or
// 412); both replicas then show the winner. Before, a bucket store locked an image per process
// only and both could answer 200, one curator's edit silently lost.
//
// And an edit published while the image is being re-ingested on the other replica is kept: the
// ingest carries the description over from the version published when it publishes, not from
// the one it started from.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <barrier>
#include <map>
#include <string>
#include <thread>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tests/support/swift_s3.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;
using testing::HttpResponse;
using testing::ServerProcess;
using testing::TempDir;

constexpr int kRounds = 100;

const std::string& portrait() {
  static const std::string bytes = testing::read_file(testing::samples_dir() + "/astronaut_portrait.png");
  return bytes;
}

// A small image: an edit copies every file of the version, and the race is about the pointer.
const std::string& small_png() {
  static const std::string bytes = [] {
    TempDir dir;
    const std::string path = dir.path() + "/small.png";
    testing::write_image(path, testing::test_pattern(96, 64, 3));
    return testing::read_file(path);
  }();
  return bytes;
}

class RacingEdits : public ::testing::Test {
 protected:
  virtual std::string store() = 0;
  virtual std::vector<std::string> own_flags(const TempDir&) { return {}; }

  // Replicas that read the store on every request, so that each shows the winner at once.
  std::unique_ptr<ServerProcess> replica(const TempDir& dir, std::vector<std::string> extra = {}) {
    std::vector<std::string> flags = own_flags(dir);
    flags.insert(flags.end(), extra.begin(), extra.end());
    for (const char* f : {"--store-recheck-ms", "0", "--gc-grace", "600"}) flags.push_back(f);
    return std::make_unique<ServerProcess>(store(), flags);
  }

  static std::string label_of(HttpClient& on, const std::string& id) {
    const HttpResponse r = on.get("/v1/images/" + id + "/metadata");
    if (r.status != 200) return "(status " + std::to_string(r.status) + ")";
    const json m = json::parse(r.body, nullptr, false);
    return m.contains("label") ? m["label"]["none"][0].get<std::string>() : "";
  }

  void race() {
    TempDir a_dir, b_dir;
    auto a = replica(a_dir), b = replica(b_dir);
    HttpClient on_a(a->port()), on_b(b->port());
    ASSERT_EQ(on_a.request("POST", "/v1/images?id=x", small_png()).status, 201);
    std::map<std::string, int> outcomes;  // "200+412" and the like, for the failure message
    for (int round = 0; round < kRounds; ++round) {
      const std::string etag = (round % 2 ? on_b : on_a).get("/v1/images/x").header("etag");
      ASSERT_FALSE(etag.empty());
      HttpResponse answers[2];
      std::barrier start(2);
      auto edit = [&](int k, HttpClient& on) {
        const std::string body = json{{"label", "round " + std::to_string(round) + " on " + "AB"[k]}}.dump();
        start.arrive_and_wait();
        answers[k] = on.request("PUT", "/v1/images/x/metadata", body,
                                {{"If-Match", etag}, {"Content-Type", "application/json"}});
      };
      std::thread on_b_thread(edit, 1, std::ref(on_b));
      edit(0, on_a);
      on_b_thread.join();
      ++outcomes[std::to_string(answers[0].status) + "+" + std::to_string(answers[1].status)];
      const int taken = (answers[0].status == 200) + (answers[1].status == 200);
      ASSERT_EQ(taken, 1) << "round " << round << ": A " << answers[0].status << " " << answers[0].body << "; B "
                          << answers[1].status << " " << answers[1].body;
      const int winner = answers[0].status == 200 ? 0 : 1, loser = 1 - winner;
      EXPECT_TRUE(answers[loser].status == 409 || answers[loser].status == 412)
          << "round " << round << ": the other edit is refused, and says so: " << answers[loser].status << " "
          << answers[loser].body;
      const std::string want = "round " + std::to_string(round) + " on " + "AB"[winner];
      EXPECT_EQ(label_of(on_a, "x"), want) << "round " << round << " on A";
      EXPECT_EQ(label_of(on_b, "x"), want) << "round " << round << " on B";
    }
    std::string summary;
    for (const auto& [k, n] : outcomes) summary += k + " ×" + std::to_string(n) + "  ";
    RecordProperty("outcomes", summary);
    std::cout << "[ outcomes ] A+B: " << summary << "\n";
  }

  // A re-upload on A takes seconds (every analysis before it publishes); an edit made on B
  // meanwhile is kept.
  void edit_during_ingest() {
    TempDir a_dir, b_dir;
    auto a = replica(a_dir, {"--analyses", "all"}), b = replica(b_dir);
    HttpClient on_a(a->port()), on_b(b->port());
    const std::string big = testing::read_file(testing::samples_dir() + "/pano_grossmugl_field_4to1.png");
    ASSERT_EQ(on_b.request("POST", "/v1/images?id=y", portrait()).status, 201);
    const std::string etag = on_b.get("/v1/images/y").header("etag");
    HttpResponse upload;
    std::thread uploading([&] { upload = on_a.request("POST", "/v1/images?id=y", big); });
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    const HttpResponse edit = on_b.request("PUT", "/v1/images/y/metadata", R"({"label": "kept"})",
                                           {{"If-Match", etag}, {"Content-Type", "application/json"}});
    uploading.join();
    ASSERT_EQ(edit.status, 200) << edit.body;
    ASSERT_EQ(upload.status, 201) << upload.body;
    EXPECT_NE(json::parse(upload.body)["width"], 512) << "the re-upload's pixels are published";
    EXPECT_EQ(label_of(on_a, "y"), "kept");
    EXPECT_EQ(label_of(on_b, "y"), "kept");
  }
};

class RacingEditsBucket : public RacingEdits {
 protected:
  void SetUp() override {
    test::SwiftS3& s3 = test::SwiftS3::shared();
    for (const auto& [k, v] : s3.environment()) ::setenv(k.c_str(), v.c_str(), 1);
    bucket_ = s3.new_bucket("race");
  }
  std::string store() override { return "s3://" + bucket_ + "/museum"; }
  std::vector<std::string> own_flags(const TempDir& dir) override {
    return {"--store-cache", dir.path(), "--store-lease-settle-ms", "20"};
  }
  std::string bucket_;
};

class RacingEditsFolder : public RacingEdits {
 protected:
  std::string store() override { return dir_.path(); }
  TempDir dir_;
};

TEST_F(RacingEditsBucket, OfTwoEditsOnOneVersionExactlyOneIsTakenAndBothReplicasShowIt) { race(); }

TEST_F(RacingEditsFolder, OfTwoEditsOnOneVersionExactlyOneIsTakenAndBothReplicasShowIt) { race(); }

TEST_F(RacingEditsBucket, AnEditMadeDuringAnIngestOnAnotherReplicaIsKept) { edit_during_ingest(); }

TEST_F(RacingEditsFolder, AnEditMadeDuringAnIngestOnAnotherReplicaIsKept) { edit_during_ingest(); }

}  // namespace
}  // namespace zoomwarp
