// `zoomwarp health`, the container health check (deploy/Dockerfile's HEALTHCHECK, deploy/compose.yaml):
// 0 when a running server answers /healthz with 200 — found through --port, ZOOMWARP_PORT or --url —
// 1 for a closed port or another status, 2 for a usage mistake; and liveness stays 0 while the
// server drains, when only readiness fails.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <optional>
#include <thread>

#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

testing::RunResult health(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {testing::zoomwarp_binary(), "health"};
  argv.insert(argv.end(), args.begin(), args.end());
  return testing::run_command(argv);
}

// Sets (or, with nullopt, unsets) an environment variable the children inherit, and restores it.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, std::optional<std::string> value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) ::setenv(name, value->c_str(), 1);
    else ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_) ::setenv(name_, old_->c_str(), 1);
    else ::unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

TEST(Health, Exits0WhenTheServerAnswers200) {
  testing::TempDir dir;
  testing::ServerProcess server(dir.path() + "/store", {"--log-requests", "0"});
  const std::string port = std::to_string(server.port());
  const ScopedEnv no_url("ZOOMWARP_URL", std::nullopt);  // would win over the port

  auto r = health({"--port", port});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("http://127.0.0.1:" + port + "/healthz: 200"), std::string::npos) << r.output;

  {  // The variable `serve` listens on is the one the health check asks.
    const ScopedEnv env("ZOOMWARP_PORT", port);
    r = health({});
    EXPECT_EQ(r.exit_code, 0) << r.output;
  }
  r = health({"--url", "http://127.0.0.1:" + port});  // no path: /healthz
  EXPECT_EQ(r.exit_code, 0) << r.output;
  r = health({"--url", "http://localhost:" + port + "/readyz"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(server.terminate(), 0);
}

TEST(Health, Exits1ForAClosedPortOrAnotherStatus) {
  const ScopedEnv no_url("ZOOMWARP_URL", std::nullopt);
  auto r = health({"--port", std::to_string(testing::unused_loopback_port()), "--timeout", "2"});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("cannot connect"), std::string::npos) << r.output;

  testing::TempDir dir;
  testing::ServerProcess server(dir.path() + "/store", {"--log-requests", "0"});
  r = health({"--url", "http://127.0.0.1:" + std::to_string(server.port()) + "/v1/images/nothing"});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("answered 404"), std::string::npos) << r.output;
}

TEST(Health, UsageMistakesExit2) {
  EXPECT_EQ(health({"--url", "ftp://127.0.0.1/healthz"}).exit_code, 2);
  EXPECT_EQ(health({"--port", "http"}).exit_code, 2);
  EXPECT_EQ(health({"--no-such-flag"}).exit_code, 2);
  EXPECT_EQ(health({"extra"}).exit_code, 2);
  auto r = health({"--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("ZOOMWARP_PORT"), std::string::npos) << r.output;
}

// A container stopped with SIGTERM must not look dead while it drains: orchestrators would kill it
// before in-flight requests finish. Liveness (/healthz, the default) stays 0; readiness fails.
TEST(Health, LivenessHoldsWhileDrainingReadinessFails) {
  testing::TempDir dir;
  testing::ServerProcess server(dir.path() + "/store", {"--log-requests", "0", "--drain-delay", "3"});
  const std::string port = std::to_string(server.port());
  ASSERT_EQ(::kill(server.pid(), SIGTERM), 0);
  // Readiness flips on the server's I/O thread right after the signal; wait for it.
  testing::RunResult ready;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  do {
    ready = health({"--url", "http://127.0.0.1:" + port + "/readyz"});
  } while (ready.exit_code == 0 && std::chrono::steady_clock::now() < deadline);
  EXPECT_EQ(ready.exit_code, 1) << ready.output;
  EXPECT_NE(ready.output.find("answered 503"), std::string::npos) << ready.output;
  auto live = health({"--port", port});
  EXPECT_EQ(live.exit_code, 0) << live.output;
  EXPECT_EQ(server.terminate(), 0);
}

}  // namespace
}  // namespace zoomwarp
