// Issue 42's expiring credentials: `zoomwarp serve` on a bucket (Swift's s3api on loopback),
// reaching it through a proxy that accepts only session tokens that have not expired
// (tests/support/fake_credentials.py), with credentials that expire every 2 s from each source
// the AWS SDKs renew: STS's AssumeRoleWithWebIdentity (a web identity token file), the container
// credentials endpoint (an authorization token file), and a shared credentials file rewritten
// with a new token every 1.5 s. Every request during 6 s of reads that each go to the store is
// answered 200; the sources were asked again and again; for the two that expire, no request was
// ever refused by the proxy (renewed before expiry). Credentials were read once at start before:
// every request failed once the first ones expired.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "tests/support/http_client.h"
#include "tests/support/server_process.h"
#include "tests/support/swift_s3.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;
using testing::ServerProcess;
using testing::TempDir;
using Clock = std::chrono::steady_clock;

constexpr double kLifetimeSeconds = 2;
constexpr double kReadingSeconds = 6;

void write_text(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  std::ofstream(tmp) << text;
  std::filesystem::rename(tmp, path);  // whole, as a secret mounted by Kubernetes changes
}

// tests/support/fake_credentials.py, its two ports read from its first line; killed at the end.
class FakeCredentials {
 public:
  explicit FakeCredentials(const std::vector<std::string>& args) {
    int out[2];
    if (::pipe(out) != 0) throw std::runtime_error("pipe");
    std::vector<std::string> argv = {"python3", ZOOMWARP_FAKE_CREDENTIALS, "--max-seconds", "300"};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> c_argv;
    for (auto& a : argv) c_argv.push_back(a.data());
    c_argv.push_back(nullptr);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(out[1], 1);
      ::close(out[0]);
      ::execvp("python3", c_argv.data());
      ::_exit(127);
    }
    ::close(out[1]);
    FILE* f = ::fdopen(out[0], "r");
    char line[256] = {};
    const bool got = std::fgets(line, sizeof line, f) != nullptr;
    std::fclose(f);
    if (!got) throw std::runtime_error("fake_credentials.py did not start");
    const json ports = json::parse(line);
    credentials_port_ = ports["credentials"], s3_port_ = ports["s3"];
  }
  ~FakeCredentials() {
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
  }
  std::string credentials_url() const { return "http://127.0.0.1:" + std::to_string(credentials_port_); }
  std::string s3_url() const { return "http://127.0.0.1:" + std::to_string(s3_port_); }
  json stats() const { return json::parse(HttpClient(credentials_port_).get("/stats").body); }

 private:
  pid_t pid_ = -1;
  int credentials_port_ = 0, s3_port_ = 0;
};

class S3Credentials : public ::testing::Test {
 protected:
  void SetUp() override {
    test::SwiftS3& s3 = test::SwiftS3::shared();
    for (const char* v : {"AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY", "AWS_SESSION_TOKEN", "AWS_ENDPOINT_URL",
                          "AWS_ENDPOINT_URL_S3", "AWS_WEB_IDENTITY_TOKEN_FILE", "AWS_ROLE_ARN",
                          "AWS_CONTAINER_CREDENTIALS_FULL_URI", "AWS_SHARED_CREDENTIALS_FILE", "AWS_PROFILE"})
      ::unsetenv(v);
    upstream_ = s3.endpoint();
    for (const auto& [k, v] : s3.environment())
      if (k == "AWS_REGION") region_ = v;
    bucket_ = s3.new_bucket("creds");
  }

  // serve on the bucket through `fake`'s proxy with `env`; reads that each go to the store for
  // kReadingSeconds (`meanwhile` runs between them); every one must be 200.
  void serve_and_read(const FakeCredentials& fake, std::vector<std::pair<std::string, std::string>> env,
                      const std::function<void()>& meanwhile = {}) {
    env.push_back({"AWS_ENDPOINT_URL_S3", fake.s3_url()});
    env.push_back({"AWS_REGION", region_});
    env.push_back({"HOME", home_.path()});  // no ~/.aws of the machine's
    testing::ServerExecutable exe;
    exe.env = env;
    ServerProcess server("s3://" + bucket_ + "/museum", {"--store-cache", cache_.path(), "--store-recheck-ms", "0"},
                         ServerProcess::Writes::kOpen, exe);
    HttpClient http(server.port());
    const std::string png = testing::read_file(testing::samples_dir() + "/astronaut_portrait.png");
    ASSERT_EQ(http.request("POST", "/v1/images?id=x", png).status, 201);
    std::map<int, int> statuses;
    const auto t0 = Clock::now();
    for (int k = 0; std::chrono::duration<double>(Clock::now() - t0).count() < kReadingSeconds; ++k) {
      // A region no request asked before (its level's blocks are cached, but the pointer is read
      // from the store every time: --store-recheck-ms 0).
      const auto r = http.get("/iiif/3/x/" + std::to_string(7 * k % 440) + "," + std::to_string(13 * k % 440) +
                              ",64,64/64,/0/default.jpg");
      ++statuses[r.status];
      EXPECT_EQ(r.status, 200) << "read " << k << ": " << r.body;
      if (meanwhile) meanwhile();
      std::this_thread::sleep_for(std::chrono::milliseconds(40));
    }
    EXPECT_GT(statuses[200], 20) << "reads made";
  }

  TempDir home_, cache_, files_;
  std::string upstream_, region_, bucket_;
};

std::vector<std::string> fake_args(const std::string& mode, const std::string& upstream) {
  return {"--mode", mode, "--upstream", upstream, "--key", test::SwiftS3::kAccessKey, "--secret", test::SwiftS3::kSecretKey,
          "--lifetime", std::to_string(kLifetimeSeconds)};
}

TEST_F(S3Credentials, WebIdentityIsRenewedAtStsBeforeItExpires) {
  const std::string token_file = files_.path() + "/web-identity-token";
  write_text(token_file, "eyJ-a-web-identity-token");
  std::vector<std::string> args = fake_args("sts", upstream_);
  args.insert(args.end(), {"--token-file", token_file});
  FakeCredentials fake(args);
  serve_and_read(fake, {{"AWS_WEB_IDENTITY_TOKEN_FILE", token_file},
                        {"AWS_ROLE_ARN", "arn:aws:iam::123456789012:role/zoomwarp"},
                        {"AWS_ENDPOINT_URL_STS", fake.credentials_url()}});
  const json stats = fake.stats();
  EXPECT_GE(stats["issued"].get<int>(), int(kReadingSeconds / kLifetimeSeconds)) << stats.dump();
  EXPECT_EQ(stats["refused"], 0) << "a request signed with an expired token: " << stats.dump();
}

TEST_F(S3Credentials, ContainerCredentialsAreRenewedBeforeTheyExpire) {
  const std::string token_file = files_.path() + "/authorization-token";
  write_text(token_file, "a-pod-identity-token");
  std::vector<std::string> args = fake_args("container", upstream_);
  args.insert(args.end(), {"--token-file", token_file});
  FakeCredentials fake(args);
  serve_and_read(fake, {{"AWS_CONTAINER_CREDENTIALS_FULL_URI", fake.credentials_url() + "/v1/credentials"},
                        {"AWS_CONTAINER_AUTHORIZATION_TOKEN_FILE", token_file}});
  const json stats = fake.stats();
  EXPECT_GE(stats["issued"].get<int>(), int(kReadingSeconds / kLifetimeSeconds)) << stats.dump();
  EXPECT_EQ(stats["refused"], 0) << "a request signed with an expired token: " << stats.dump();
}

TEST_F(S3Credentials, ARotatedSharedCredentialsFileIsReadAgain) {
  const std::string file = files_.path() + "/credentials";
  int rotation = 0;
  auto rotate = [&] {
    write_text(file, "[default]\naws_access_key_id = " + std::string(test::SwiftS3::kAccessKey) +
                         "\naws_secret_access_key = " + test::SwiftS3::kSecretKey +
                         "\naws_session_token = file-token-" + std::to_string(++rotation) + "\n");
  };
  rotate();
  std::vector<std::string> args = fake_args("file", upstream_);
  args.insert(args.end(), {"--credentials-file", file});
  FakeCredentials fake(args);
  auto last = Clock::now();
  serve_and_read(fake, {{"AWS_SHARED_CREDENTIALS_FILE", file}}, [&] {
    if (Clock::now() - last > std::chrono::milliseconds(1500)) rotate(), last = Clock::now();
  });
  EXPECT_GE(rotation, 3);
  // Requests signed with the old token before the file was looked at again were refused, renewed
  // and sent again: none failed.
  std::cout << "[ figures ] " << rotation << " rotations, the proxy refused " << fake.stats()["refused"]
            << " requests signed with a token just rotated out\n";
}

}  // namespace
}  // namespace zoomwarp
