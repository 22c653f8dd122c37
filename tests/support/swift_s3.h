// A real S3 server for the tests: OpenStack Swift with its s3api middleware and a memcached, on
// 127.0.0.1 (tests/support/swift_s3/: start.sh, stop.sh, README.md). Debian's python3-swift and
// memcached, installed by scripts/setup.sh.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <string>
#include <utility>
#include <vector>

namespace zoomwarp::test {

// One OpenStack Swift + s3api server on 127.0.0.1 per test process, started on first use of
// shared() (3-7 s) and stopped when the process exits; every test suite shares it and makes its
// own buckets. Path-style, region us-east-1.
//
// Its processes end with the test process however that ends (exit, crash, SIGKILL, a ctest
// timeout): a watchdog in their process group stops them when a pipe only the test process holds
// the write end of reads end-of-file. Register a test binary's S3 suites as one-process suites
// (zoomwarp_add_gtests in tests/CMakeLists.txt): every process pays the start (and ~220 MB RSS).
class SwiftS3 {
 public:
  // Starts it; on failure fails loudly (throws std::runtime_error with the log tail). A failed
  // start is not tried again: later calls throw the same error at once.
  static SwiftS3& shared();
  const std::string& endpoint() const { return endpoint_; }  // "http://127.0.0.1:PORT"
  static constexpr const char* kAccessKey = "test:tester";
  static constexpr const char* kSecretKey = "testing";
  static constexpr const char* kRegion = "us-east-1";
  // Creates a fresh empty bucket with a unique valid name (DNS-style, lower case, >= 3 chars):
  // HINT made DNS-safe (at most 30 characters), "-PID-N". Throws unless the server answers 200.
  std::string new_bucket(const std::string& hint = "t");
  // The AWS_* environment a child process (zoomwarp serve/ingest) needs to reach it:
  // AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY, AWS_REGION, AWS_ENDPOINT_URL_S3.
  std::vector<std::pair<std::string, std::string>> environment() const;
  // SIGSTOP the proxy server process: the store hangs (connections accepted by the kernel, no
  // answers). Returns once the process is stopped.
  void pause();
  // SIGCONT it. Returns once it runs again.
  void resume();
  // GET /healthcheck answers 200 within 1 s.
  bool healthy() const;

  // Not S3, for debugging and the fixture's own test: the server's folder (etc/ configs, log/
  // each server's log, pids) and how long the start took.
  const std::string& state_dir() const { return dir_; }
  double start_seconds() const { return start_seconds_; }

  SwiftS3(const SwiftS3&) = delete;
  SwiftS3& operator=(const SwiftS3&) = delete;
  ~SwiftS3();

 private:
  SwiftS3();
  void stop();

  std::string dir_;
  std::string endpoint_;
  int port_ = 0;
  pid_t proxy_pid_ = -1;
  pid_t owner_pid_ = -1;
  int watch_fd_ = -1;  // the pipe's write end: closed, the watchdog stops the server
  double start_seconds_ = 0;
  std::atomic<int> buckets_{0};
};

}  // namespace zoomwarp::test
