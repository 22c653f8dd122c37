// The S3 test fixture (tests/support/swift_s3.h): a real Swift + s3api server on loopback answers
// signed S3 requests byte for byte, buckets are separate, pause() hangs it and resume() brings it
// back, and none of its processes outlives a test process that is SIGKILLed. Requests are made
// with the curl CLI, as tests/support/swift_s3/README.md shows them, not with the code under test.
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"
#include "tests/support/swift_s3.h"

namespace zoomwarp::test {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using zoomwarp::testing::read_file;
using zoomwarp::testing::run_command;
using zoomwarp::testing::TempDir;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The wall clock as the watchdog's log writes it (date -u +%FT%T.%3NZ), to set the two side by side.
std::string utc_now() {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                      std::chrono::system_clock::now().time_since_epoch()).count();
  const std::time_t t = std::time_t(ms / 1000);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[40];
  const std::size_t n = std::strftime(buf, sizeof buf, "%FT%T", &tm);
  std::snprintf(buf + n, sizeof buf - n, ".%03dZ", int(ms % 1000));
  return buf;
}

struct Curl {
  int exit_code = -1;  // curl's: 28 is a timeout
  int status = 0;      // HTTP status, 0 without an answer
  std::string output;
};

// The curl CLI with a SigV4-signed request to PATH: the credentials in the URL (the access key
// holds a colon), x-amz-content-sha256 sent by hand (curl 7.88 does not, s3api requires it).
Curl curl_s3(const SwiftS3& s3, const std::string& path, const std::vector<std::string>& args) {
  const std::string endpoint = s3.endpoint();
  const std::string url = "http://test%3Atester:testing@" + endpoint.substr(std::string("http://").size()) + path;
  std::vector<std::string> argv = {"/usr/bin/curl", "-sS", "--aws-sigv4", "aws:amz:us-east-1:s3",
                                   "-H", "x-amz-content-sha256: UNSIGNED-PAYLOAD", "-w", "\nstatus=%{http_code}\n"};
  argv.insert(argv.end(), args.begin(), args.end());
  argv.push_back(url);
  const auto r = run_command(argv);
  Curl c;
  c.exit_code = r.exit_code;
  c.output = r.output;
  std::smatch m;
  if (std::regex_search(c.output, m, std::regex("status=(\\d{3})"))) c.status = std::stoi(m[1]);
  return c;
}

std::string random_bytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::string out(n, '\0');
  for (auto& c : out) c = static_cast<char>(rng() & 0xff);
  return out;
}

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// Resumes the server however the test leaves its scope: later tests share it.
struct ResumeAtEnd {
  SwiftS3& s3;
  ~ResumeAtEnd() { s3.resume(); }
};

TEST(SwiftS3Fixture, StartsOnLoopbackAndMakesBuckets) {
  const auto t0 = Clock::now();
  SwiftS3& s3 = SwiftS3::shared();
  std::cout << "SwiftS3 started in " << s3.start_seconds() << " s (shared() " << seconds_since(t0) << " s), "
            << s3.endpoint() << ", state in " << s3.state_dir() << std::endl;
  RecordProperty("start_seconds", std::to_string(s3.start_seconds()));
  EXPECT_TRUE(std::regex_match(s3.endpoint(), std::regex(R"(http://127\.0\.0\.1:\d+)"))) << s3.endpoint();
  EXPECT_EQ(&SwiftS3::shared(), &s3);
  EXPECT_TRUE(s3.healthy());

  const std::string a = s3.new_bucket();
  const std::string b = s3.new_bucket("Fixture_Test.B");
  EXPECT_NE(a, b);
  const std::regex dns(R"([a-z0-9][a-z0-9-]{1,61}[a-z0-9])");
  EXPECT_TRUE(std::regex_match(a, dns)) << a;
  EXPECT_TRUE(std::regex_match(b, dns)) << b;
  EXPECT_EQ(b.rfind("fixture-test-b-", 0), 0u) << b;

  const Curl list = curl_s3(s3, "/", {});
  ASSERT_EQ(list.status, 200) << list.output;
  EXPECT_NE(list.output.find("<Name>" + a + "</Name>"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("<Name>" + b + "</Name>"), std::string::npos) << list.output;
  for (const std::string& bucket : {a, b}) {
    const Curl empty = curl_s3(s3, "/" + bucket + "?list-type=2", {});
    EXPECT_EQ(empty.status, 200) << empty.output;
    EXPECT_EQ(empty.output.find("<Contents>"), std::string::npos) << "a new bucket is empty: " << empty.output;
  }
}

TEST(SwiftS3Fixture, ObjectsComeBackByteForByteAndByRange) {
  SwiftS3& s3 = SwiftS3::shared();
  const std::string a = s3.new_bucket("bytes");
  const std::string b = s3.new_bucket("other");
  TempDir dir;
  const std::string bytes = random_bytes(300 * 1024 + 7, 29);
  write_file(dir.path() + "/object", bytes);

  const Curl put = curl_s3(s3, "/" + a + "/dir/object.bin", {"-X", "PUT", "--data-binary", "@" + dir.path() + "/object"});
  ASSERT_EQ(put.status, 200) << put.output;

  const Curl get = curl_s3(s3, "/" + a + "/dir/object.bin", {"-o", dir.path() + "/got"});
  ASSERT_EQ(get.status, 200) << get.output;
  EXPECT_TRUE(read_file(dir.path() + "/got") == bytes) << "the object differs from what was put";

  const Curl range = curl_s3(s3, "/" + a + "/dir/object.bin", {"-H", "Range: bytes=100000-116383", "-o", dir.path() + "/range"});
  ASSERT_EQ(range.status, 206) << range.output;
  EXPECT_TRUE(read_file(dir.path() + "/range") == bytes.substr(100000, 16384)) << "the range differs";

  const Curl last = curl_s3(s3, "/" + a + "/dir/object.bin", {"-H", "Range: bytes=-5", "-o", dir.path() + "/last"});
  ASSERT_EQ(last.status, 206) << last.output;
  EXPECT_TRUE(read_file(dir.path() + "/last") == bytes.substr(bytes.size() - 5));

  const Curl elsewhere = curl_s3(s3, "/" + b + "/dir/object.bin", {"-o", "/dev/null"});
  EXPECT_EQ(elsewhere.status, 404) << "buckets are separate: " << elsewhere.output;

  // A listing with a prefix: the query sorted by name and percent-encoded, as curl 7.88 signs it
  // as written.
  const Curl list = curl_s3(s3, "/" + a + "?list-type=2&prefix=dir%2F", {});
  ASSERT_EQ(list.status, 200) << list.output;
  EXPECT_NE(list.output.find("<Key>dir/object.bin</Key>"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("<Size>" + std::to_string(bytes.size()) + "</Size>"), std::string::npos) << list.output;
}

TEST(SwiftS3Fixture, EnvironmentNamesTheServer) {
  SwiftS3& s3 = SwiftS3::shared();
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"AWS_ACCESS_KEY_ID", "test:tester"},
      {"AWS_SECRET_ACCESS_KEY", "testing"},
      {"AWS_REGION", "us-east-1"},
      {"AWS_ENDPOINT_URL_S3", s3.endpoint()}};
  EXPECT_EQ(s3.environment(), expected);
}

TEST(SwiftS3Fixture, PauseHangsRequestsAndResumeAnswersThemAgain) {
  SwiftS3& s3 = SwiftS3::shared();
  const std::string bucket = s3.new_bucket("pause");
  TempDir dir;
  const std::string bytes = random_bytes(4096, 7);
  write_file(dir.path() + "/object", bytes);
  ASSERT_EQ(curl_s3(s3, "/" + bucket + "/o", {"-X", "PUT", "--data-binary", "@" + dir.path() + "/object"}).status, 200);
  {
    s3.pause();
    ResumeAtEnd resume{s3};
    auto t0 = Clock::now();
    EXPECT_FALSE(s3.healthy());
    EXPECT_LT(seconds_since(t0), 3.0) << "healthy() is bounded by 1 s";
    t0 = Clock::now();
    const Curl hung = curl_s3(s3, "/" + bucket + "/o", {"-m", "2", "-o", "/dev/null"});
    const double waited = seconds_since(t0);
    EXPECT_EQ(hung.exit_code, 28) << "a request to the paused store times out: " << hung.output;
    EXPECT_EQ(hung.status, 0) << hung.output;
    EXPECT_GE(waited, 1.9);
    EXPECT_LT(waited, 5.0);
  }
  EXPECT_TRUE(s3.healthy());
  const Curl get = curl_s3(s3, "/" + bucket + "/o", {"-m", "10", "-o", dir.path() + "/got"});
  ASSERT_EQ(get.status, 200) << get.output;
  EXPECT_TRUE(read_file(dir.path() + "/got") == bytes);
}

// Live processes whose environment carries the fixture's mark for DIR (start.sh exports
// ZOOMWARP_SWIFT_S3=DIR to all it starts): the watchdog, memcached and the four Swift servers.
std::vector<pid_t> marked_processes(const std::string& dir) {
  std::vector<pid_t> out;
  const std::string mark = std::string("ZOOMWARP_SWIFT_S3=") + dir + '\0';
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::string stat = read_file(entry.path() / "stat");
    const auto paren = stat.rfind(')');
    if (paren == std::string::npos || paren + 2 >= stat.size() || stat[paren + 2] == 'Z') continue;
    const std::string environ = '\0' + read_file(entry.path() / "environ");
    if (environ.find('\0' + mark) != std::string::npos) out.push_back(std::stoi(name));
  }
  return out;
}

// Run by the next test in a process of its own: starts its own server, pauses it (a stopped
// process is the hard case: it cannot notice anything itself), says where it is, and waits to be
// killed.
TEST(SwiftS3Fixture, DISABLED_ChildHoldingAPausedServer) {
  SwiftS3& s3 = SwiftS3::shared();
  s3.pause();
  std::cout << "state_dir=" << s3.state_dir() << "\nproxy paused" << std::endl;
  std::this_thread::sleep_for(std::chrono::minutes(5));
}

// A child test process holding its own paused server (the test above), and that server's folder.
struct ChildServer {
  pid_t pid = -1;
  std::string state_dir;
};

// Starts the child and waits until its server is up and paused; FAILs (with pid -1) otherwise.
void start_child_holding_a_paused_server(const std::string& log, ChildServer& out) {
  const std::string self = fs::read_symlink("/proc/self/exe");
  std::string filter = "--gtest_filter=SwiftS3Fixture.DISABLED_ChildHoldingAPausedServer";
  std::string disabled = "--gtest_also_run_disabled_tests";
  std::vector<std::string> argv_s = {self, filter, disabled};
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t self_pid = ::getpid();
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // killed with this test process, should that come first
    if (::getppid() != self_pid) ::_exit(1);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
    }
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  const auto t0 = Clock::now();
  const std::regex line(R"(state_dir=(\S+)\nproxy paused)");
  while (seconds_since(t0) < 90) {
    std::smatch m;
    const std::string text = read_file(log);
    if (std::regex_search(text, m, line)) {
      out = {child, m[1]};
      std::cout << "the child's server started in " << seconds_since(t0) << " s" << std::endl;
      return;
    }
    int status = 0;
    if (::waitpid(child, &status, WNOHANG) == child) FAIL() << "the child ended:\n" << text;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ::kill(child, SIGKILL);
  ::waitpid(child, nullptr, 0);
  FAIL() << "the child did not start its server:\n" << read_file(log);
}

// Kills the child; then, with HANG_UP, sends its server's process group what the kernel sends an
// orphaned process group that holds a stopped process when it becomes orphaned (SIGHUP, then
// SIGCONT: POSIX, "_exit"). Whether and when the kernel does so depends on who reaps the
// fixture's processes on the machine: the same session's init or subreaper, or one outside it.
// Then checks that every process of that server and its folder are gone.
void kill_child_and_expect_its_server_gone(const ChildServer& child, bool hang_up) {
  const std::vector<pid_t> before = marked_processes(child.state_dir);
  EXPECT_EQ(before.size(), 6u) << "watchdog, memcached and four Swift servers:\n"
                               << read_file(child.state_dir + "/pids");
  const pid_t group = std::stoi(read_file(child.state_dir + "/pgid"));
  ::kill(child.pid, SIGKILL);
  ::waitpid(child.pid, nullptr, 0);
  const auto killed = Clock::now();
  const std::string killed_utc = utc_now();
  if (hang_up) {
    ::kill(-group, SIGHUP);
    ::kill(-group, SIGCONT);
  }
  // A bound for a hang, not a timing: it takes ~0.3 s.
  while ((!marked_processes(child.state_dir).empty() || fs::exists(child.state_dir)) && seconds_since(killed) < 60) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::cout << "killed the child at " << killed_utc << "; its processes and folder were gone "
            << seconds_since(killed) << " s after the SIGKILL" << std::endl;
  EXPECT_TRUE(marked_processes(child.state_dir).empty()) << "left behind after the test process was killed";
  EXPECT_FALSE(fs::exists(child.state_dir)) << child.state_dir << " left behind; the watchdog's log:\n"
                                            << read_file(child.state_dir + ".watchdog.log");
  EXPECT_FALSE(fs::exists(child.state_dir + ".watchdog.log")) << "the log of a watchdog that did its work is removed";
}

TEST(SwiftS3Fixture, ItsProcessesEndWhenTheTestProcessIsKilled) {
  SwiftS3& parent = SwiftS3::shared();  // started before, so the child's start is measured alone
  TempDir dir;
  ChildServer child;
  start_child_holding_a_paused_server(dir.path() + "/child.log", child);
  if (child.pid < 0) return;
  EXPECT_NE(child.state_dir, parent.state_dir());
  kill_child_and_expect_its_server_gone(child, false);
  EXPECT_TRUE(parent.healthy()) << "another process's server is not touched";
}

// CI twice found the folder of a killed child left behind: every process gone, the watchdog's log
// ending after stop.sh's first round of SIGKILLs. The watchdog and stop.sh had ended half-way, as a
// signal to their group ends them (reproduced here with SIGHUP; which signal CI's machine sent, and
// why, is not known: the kernel's orphaned-group SIGHUP is the likeliest).
TEST(SwiftS3Fixture, ItsWatchdogOutlivesAHangupOfItsGroup) {
  SwiftS3& parent = SwiftS3::shared();
  TempDir dir;
  ChildServer child;
  start_child_holding_a_paused_server(dir.path() + "/child.log", child);
  if (child.pid < 0) return;
  kill_child_and_expect_its_server_gone(child, true);
  EXPECT_TRUE(parent.healthy()) << "another process's server is not touched";
}

}  // namespace
}  // namespace zoomwarp::test
