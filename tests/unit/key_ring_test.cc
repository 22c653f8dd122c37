// The key file format (api/key_ring.h) and how the key ring judges Authorization headers.
#include "api/key_ring.h"

#include <gtest/gtest.h>

#include <fstream>

#include "tests/support/server_process.h"

namespace zoomwarp::api {
namespace {

using Outcome = Authenticator::Outcome;

constexpr std::string_view kCuratorKey = "curator-key-0123456789";

// The digests are computed independently of the code under test:
//   printf '%s' 'the-admin-key-0123' | sha256sum       (the sha256: line)
//   printf '%s' 'curator-key-0123456789' | sha256sum   (kCuratorKey, given as it is)
constexpr std::string_view kAdminKeySha256 = "a06a4fd502bcc6f80a5b5be7f8b68a1ce94fc7b3d839bdbd4679f2f10089f482";
constexpr std::string_view kCuratorKeySha256 = "73b73c62a3788812eca0349ca1f769d2c2d15d63ad403d1951df62279df000b7";

TEST(KeyFile, ParsesKeysCommentsBlankLinesAndDigests) {
  const std::string text = "# id role key\n\n  alice\tcurator  " + std::string(kCuratorKey) +
                           "\r\nops admin sha256:" + std::string(kAdminKeySha256) + "\n";
  const auto keys = parse_key_file(text);
  ASSERT_EQ(keys.size(), 2u);
  EXPECT_EQ(keys[0].key_id, "alice");
  EXPECT_EQ(keys[0].role, Role::kCurator);
  EXPECT_EQ(digest_hex(keys[0].digest), kCuratorKeySha256);
  EXPECT_EQ(keys[1].key_id, "ops");
  EXPECT_EQ(keys[1].role, Role::kAdmin);
  EXPECT_EQ(digest_hex(keys[1].digest), kAdminKeySha256);
  EXPECT_EQ(keys[1].digest, key_digest("the-admin-key-0123")) << "the key the sha256: line stands for";
}

// Each malformed file is refused with a message naming the line, and never quoting the key.
TEST(KeyFile, RefusesMalformedLinesWithoutQuotingTheKey) {
  const std::string secret = "secret-secret-secret";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"alice curator\n", "line 1: expected KEY_ID ROLE KEY"},
      {"alice curator " + secret + " extra\n", "line 1: expected KEY_ID ROLE KEY"},
      {"# ok\nal/ice curator " + secret + "\n", "line 2: a key id"},
      {std::string(65, 'a') + " curator " + secret + "\n", "line 1: a key id"},
      {"alice owner " + secret + "\n", "line 1: the role must be"},
      {"alice curator short-" + std::string(9, 'x') + "\n", "line 1: the key is shorter than 16"},  // 15
      {"alice curator sha256:abcd\n", "line 1: a sha256: key must be followed by 64 hex digits"},
      {"alice curator sha256:" + std::string(64, 'g') + "\n", "line 1: a sha256: key"},
      {"a reader " + secret + "\na curator other-" + secret + "\n", "line 2: key id 'a' is given twice"},
      {"a reader " + secret + "\nb curator " + secret + "\n", "line 2: the same key"},
      {"# nothing\n\n", "holds no keys"},
  };
  for (const auto& [text, expected] : cases) {
    try {
      parse_key_file(text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const KeyFileError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find(secret), std::string::npos) << e.what();
    }
  }
}

TEST(KeyFile, RandomKeysAreLongDistinctAndHeaderSafe) {
  const std::string a = random_key(), b = random_key();
  EXPECT_EQ(a.size(), 43u);
  EXPECT_NE(a, b);
  EXPECT_EQ(a.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_"), std::string::npos);
}

class KeyRingTest : public ::testing::Test {
 protected:
  void write(const std::string& text) { std::ofstream(path_, std::ios::trunc) << text; }
  zoomwarp::testing::TempDir dir_;
  std::string path_ = dir_.path() + "/keys";
};

TEST_F(KeyRingTest, JudgesBearerHeaders) {
  write("alice curator " + std::string(kCuratorKey) + "\n");
  KeyRing ring(path_);
  EXPECT_TRUE(ring.has_keys());
  EXPECT_EQ(ring.authenticate("").outcome, Outcome::kNoCredentials);
  const auto ok = ring.authenticate("Bearer " + std::string(kCuratorKey));
  EXPECT_EQ(ok.outcome, Outcome::kValid);
  EXPECT_EQ(ok.principal.key_id, "alice");
  EXPECT_EQ(ok.principal.role, Role::kCurator);
  EXPECT_EQ(ring.authenticate("bearer  " + std::string(kCuratorKey) + " ").outcome, Outcome::kValid);
  EXPECT_EQ(ring.authenticate("Bearer " + std::string(kCuratorKey) + "x").outcome, Outcome::kInvalid);
  EXPECT_EQ(ring.authenticate("Basic " + std::string(kCuratorKey)).outcome, Outcome::kInvalid);
  EXPECT_EQ(ring.authenticate("Bearer").outcome, Outcome::kInvalid);
}

TEST_F(KeyRingTest, ReloadSwapsKeysAndKeepsThemWhenTheNewFileIsMalformed) {
  write("alice curator " + std::string(kCuratorKey) + "\n");
  std::vector<std::string> logged;
  KeyRing ring(path_, [&](std::string_view level, std::string_view msg) { logged.push_back(std::string(level) + ": " + std::string(msg)); });
  write("bob admin new-admin-key-0123456789\n");
  EXPECT_TRUE(ring.reload());
  EXPECT_EQ(ring.authenticate("Bearer " + std::string(kCuratorKey)).outcome, Outcome::kInvalid);
  EXPECT_EQ(ring.authenticate("Bearer new-admin-key-0123456789").principal.role, Role::kAdmin);
  write("bob admin new-admin-key-0123456789\nbroken\n");
  EXPECT_FALSE(ring.reload());
  EXPECT_EQ(ring.authenticate("Bearer new-admin-key-0123456789").outcome, Outcome::kValid);
  ASSERT_FALSE(logged.empty());
  EXPECT_EQ(logged.back().rfind("error: ", 0), 0u) << logged.back();
  EXPECT_NE(logged.back().find("line 2"), std::string::npos) << logged.back();
}

TEST_F(KeyRingTest, RefusesAMalformedOrMissingFileAtConstruction) {
  write("alice curator short\n");
  EXPECT_THROW(KeyRing ring(path_), KeyFileError);
  EXPECT_THROW(KeyRing ring(dir_.path() + "/absent"), std::runtime_error);
}

}  // namespace
}  // namespace zoomwarp::api
