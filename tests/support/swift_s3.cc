#include "tests/support/swift_s3.h"

#include <curl/curl.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <arpa/inet.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace zoomwarp::test {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// tests/support/swift_s3/ in the source tree (start.sh, stop.sh, swiftd.py).
const char* const kScripts = ZOOMWARP_SWIFT_S3_SCRIPTS;
// How long start.sh waits for a signed S3 request to work; the fixture waits a little longer for
// start.sh itself.
constexpr int kStartTimeoutSeconds = 60;
// The fd the watchdog reads in start.sh's process (S3_WATCH_FD).
constexpr int kWatchFd = 3;

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string tail(const std::string& text, std::size_t lines) {
  std::size_t pos = text.size();
  for (std::size_t n = 0; n <= lines && pos > 0; ++n) {
    pos = text.rfind('\n', pos - 1);
    if (pos == std::string::npos) return text;
  }
  return text.substr(pos + 1);
}

// The process state letter of /proc/PID/stat (R, S, T, Z, ...), or 0 when there is no such process.
char process_state(pid_t pid) {
  const std::string stat = read_text("/proc/" + std::to_string(pid) + "/stat");
  const auto paren = stat.rfind(')');
  if (paren == std::string::npos || paren + 2 >= stat.size()) return 0;
  return stat[paren + 2];
}

bool loopback_port_free(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = htons(static_cast<uint16_t>(port));
  const bool free = ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  ::close(fd);
  return free;
}

// A base port P with P..P+4 free on 127.0.0.1, chosen at random outside the kernel's ephemeral
// range (where `--port 0` servers and outgoing connections take theirs while we start).
int pick_port_base() {
  int low = 32768, high = 60999;
  std::ifstream("/proc/sys/net/ipv4/ip_local_port_range") >> low >> high;
  int from = 10000, to = low - 5;
  if (to - from < 1000) from = high + 1, to = 65530;
  std::mt19937 rng(std::random_device{}());
  std::uniform_int_distribution<int> pick(from, to);
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int base = pick(rng);
    bool free = true;
    for (int i = 0; i < 5 && free; ++i) free = loopback_port_free(base + i);
    if (free) return base;
  }
  throw std::runtime_error("SwiftS3: found no five free consecutive loopback ports");
}

std::string temp_root() {
  const char* tmp = std::getenv("TMPDIR");
  return tmp && *tmp ? tmp : "/tmp";
}
constexpr const char* kStatePrefix = "zoomwarp-swift-s3-";

std::string make_state_dir() {
  std::string pattern = temp_root() + "/" + kStatePrefix + "XXXXXX";
  if (!::mkdtemp(pattern.data())) {
    throw std::runtime_error("SwiftS3: mkdtemp " + pattern + ": " + std::strerror(errno));
  }
  return fs::canonical(pattern).string();  // as start.sh marks its processes (pwd -P)
}

// Folders of earlier fixtures that nothing runs in any more: a live server always has processes
// marked ZOOMWARP_SWIFT_S3=FOLDER (its watchdog at least, started first), so an unmarked folder of
// ours older than a minute was left by something that killed the watchdog too (kill -9 of the whole
// process group, the OOM killer). Stopping processes is the watchdog's job; this only tidies, its old
// logs too.
void remove_stale_state_dirs() {
  std::error_code ec;
  std::vector<fs::path> candidates;
  for (const auto& entry : fs::directory_iterator(temp_root(), ec)) {
    const std::string name = entry.path().filename().string();
    struct stat st {};
    if (name.rfind(kStatePrefix, 0) != 0 || ::lstat(entry.path().c_str(), &st) != 0 || st.st_uid != ::getuid() ||
        ::time(nullptr) - st.st_mtime < 60) {
      continue;
    }
    if (S_ISREG(st.st_mode) && name.ends_with(".watchdog.log")) {  // a watchdog's report on a folder it left
      fs::remove(entry.path(), ec);
      continue;
    }
    if (!S_ISDIR(st.st_mode)) continue;
    candidates.push_back(entry.path());
  }
  if (candidates.empty()) return;
  std::string marks;  // every live process's environment
  for (const auto& entry : fs::directory_iterator("/proc", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    marks += '\0' + read_text(entry.path().string() + "/environ");
  }
  marks += '\0';
  for (const auto& dir : candidates) {
    const std::string mark = std::string(1, '\0') + "ZOOMWARP_SWIFT_S3=" + fs::canonical(dir, ec).string() + '\0';
    if (!ec && marks.find(mark) == std::string::npos) {
      fs::remove_all(dir, ec);
    }
  }
}

// The test's environment with VARS set (replacing any of the same name). Made before fork: the
// child of a threaded process may only call async-signal-safe functions.
std::vector<std::string> environment_with(const std::vector<std::pair<std::string, std::string>>& vars) {
  std::vector<std::string> out;
  for (char** e = environ; *e; ++e) {
    const std::string entry = *e;
    bool replaced = false;
    for (const auto& [name, value] : vars) replaced = replaced || entry.rfind(name + "=", 0) == 0;
    if (!replaced) out.push_back(entry);
  }
  for (const auto& [name, value] : vars) out.push_back(name + "=" + value);
  return out;
}

struct ScriptResult {
  int exit_code = -1;  // -1: killed, or did not end in time
  std::string output;  // stdout and stderr
};

// Runs bash SCRIPT with VARS added to the environment, to its end or for at most TIMEOUT; its
// output through a pipe. WATCH_FD, if >= 0, becomes its fd kWatchFd. The script leads a process
// group of its own (start.sh's processes live in it) and is SIGKILLed if the test process dies
// while it runs (PR_SET_PDEATHSIG; the waiting thread is its parent and outlives it).
ScriptResult run_script(const std::string& script, const std::vector<std::pair<std::string, std::string>>& vars,
                        int watch_fd, std::chrono::seconds timeout) {
  std::vector<std::string> env = environment_with(vars);
  std::vector<char*> envp;
  for (auto& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::string bash = "/bin/bash";
  std::string path = script;
  char* argv[] = {bash.data(), path.data(), nullptr};
  int out[2];
  if (::pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("SwiftS3: pipe2 failed");
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(out[0]);
    ::close(out[1]);
    throw std::runtime_error("SwiftS3: fork failed");
  }
  if (pid == 0) {
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(126);
    const int null = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (null >= 0) ::dup2(null, STDIN_FILENO);
    ::dup2(out[1], STDOUT_FILENO);
    ::dup2(out[1], STDERR_FILENO);
    if (watch_fd >= 0) {
      if (watch_fd == kWatchFd) {
        ::fcntl(kWatchFd, F_SETFD, 0);  // dup2 onto itself would leave close-on-exec set
      } else {
        ::dup2(watch_fd, kWatchFd);
      }
    }
    ::execve(argv[0], argv, envp.data());
    ::_exit(127);
  }
  ::close(out[1]);
  ScriptResult result;
  const auto deadline = Clock::now() + timeout;
  bool timed_out = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) {
      timed_out = true;
      break;
    }
    pollfd p{out[0], POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::min<long long>(left, 1000)));
    if (ready < 0 && errno != EINTR) break;
    if (ready <= 0) continue;
    char buf[4096];
    const ssize_t n = ::read(out[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // end of file: the script and everything holding its output are done
    result.output.append(buf, static_cast<std::size_t>(n));
  }
  ::close(out[0]);
  if (timed_out) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!timed_out && WIFEXITED(status)) result.exit_code = WEXITSTATUS(status);
  if (timed_out) result.output += "\n(SwiftS3: " + script + " did not end within " +
                                  std::to_string(timeout.count()) + " s)";
  return result;
}

void run_stop(const std::string& dir) {
  run_script(std::string(kScripts) + "/stop.sh", {{"S3_DIR", dir}, {"S3_KEEP", ""}}, -1, std::chrono::seconds(30));
}

size_t append_body(char* data, size_t size, size_t count, void* body) {
  static_cast<std::string*>(body)->append(data, size * count);
  return size * count;
}

struct CurlResponse {
  long status = 0;  // 0: no answer
  std::string body;
  std::string error;
};

// One request to the server; SIGNED adds AWS SigV4 (libcurl's) with the fixture's credentials.
CurlResponse curl_request(const std::string& method, const std::string& url, bool sign, long timeout_ms) {
  std::unique_ptr<CURL, decltype(&curl_easy_cleanup)> curl(curl_easy_init(), &curl_easy_cleanup);
  if (!curl) throw std::runtime_error("SwiftS3: curl_easy_init failed");
  CurlResponse response;
  char error[CURL_ERROR_SIZE] = "";
  CURL* c = curl.get();
  curl_easy_setopt(c, CURLOPT_URL, url.c_str());
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(c, CURLOPT_TIMEOUT_MS, timeout_ms);
  curl_easy_setopt(c, CURLOPT_ERRORBUFFER, error);
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, append_body);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &response.body);
  if (method == "PUT") {
    // An empty body with its Content-Length: 0.
    curl_easy_setopt(c, CURLOPT_CUSTOMREQUEST, "PUT");
    curl_easy_setopt(c, CURLOPT_POSTFIELDS, "");
    curl_easy_setopt(c, CURLOPT_POSTFIELDSIZE, 0L);
  } else if (method != "GET") {
    curl_easy_setopt(c, CURLOPT_CUSTOMREQUEST, method.c_str());
  }
  curl_slist* headers = nullptr;
  if (sign) {
    // The key holds a colon: USERNAME and PASSWORD, not USERPWD. curl 7.88 does not send
    // x-amz-content-sha256, which s3api requires.
    curl_easy_setopt(c, CURLOPT_AWS_SIGV4, (std::string("aws:amz:") + SwiftS3::kRegion + ":s3").c_str());
    curl_easy_setopt(c, CURLOPT_USERNAME, SwiftS3::kAccessKey);
    curl_easy_setopt(c, CURLOPT_PASSWORD, SwiftS3::kSecretKey);
    headers = curl_slist_append(headers, "x-amz-content-sha256: UNSIGNED-PAYLOAD");
    curl_easy_setopt(c, CURLOPT_HTTPHEADER, headers);
  }
  const CURLcode code = curl_easy_perform(c);
  curl_slist_free_all(headers);
  if (code == CURLE_OK) {
    curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &response.status);
  } else {
    response.error = error[0] ? error : curl_easy_strerror(code);
  }
  return response;
}

// HINT as the start of a bucket name: lower-case letters, digits and single hyphens, at most 30.
std::string dns_safe(const std::string& hint) {
  std::string out;
  for (char ch : hint) {
    char c = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9'))) c = '-';
    if (c == '-' && (out.empty() || out.back() == '-')) continue;
    out.push_back(c);
    if (out.size() == 30) break;
  }
  while (!out.empty() && out.back() == '-') out.pop_back();
  return out.empty() ? "t" : out;
}

}  // namespace

SwiftS3& SwiftS3::shared() {
  static std::mutex mutex;
  static std::unique_ptr<SwiftS3> instance;
  static std::string failure;
  std::lock_guard<std::mutex> lock(mutex);
  if (instance) return *instance;
  if (!failure.empty()) throw std::runtime_error(failure);
  try {
    instance.reset(new SwiftS3());
  } catch (const std::exception& e) {
    failure = e.what();
    throw;
  }
  return *instance;
}

SwiftS3::SwiftS3() : owner_pid_(::getpid()) {
  const auto t0 = Clock::now();
  if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) throw std::runtime_error("SwiftS3: curl_global_init failed");
  int watch[2];
  if (::pipe2(watch, O_CLOEXEC) != 0) throw std::runtime_error("SwiftS3: pipe2 failed");
  watch_fd_ = watch[1];
  remove_stale_state_dirs();
  std::string error;
  // Another process may take one of the five ports between the check and the bind: try again
  // elsewhere then, not on other failures.
  for (int attempt = 0; attempt < 3; ++attempt) {
    try {
      port_ = pick_port_base();
      dir_ = make_state_dir();
    } catch (...) {
      ::close(watch[0]);
      ::close(watch[1]);
      throw;
    }
    const ScriptResult r = run_script(std::string(kScripts) + "/start.sh",
                                      {{"S3_DIR", dir_},
                                       {"S3_PORT", std::to_string(port_)},
                                       {"S3_WATCH_FD", std::to_string(kWatchFd)},
                                       {"S3_WATCH_PID", std::to_string(owner_pid_)},
                                       {"S3_KEEP", ""},
                                       {"S3_START_TIMEOUT", std::to_string(kStartTimeoutSeconds)}},
                                      watch[0], std::chrono::seconds(kStartTimeoutSeconds + 30));
    if (r.exit_code == 0) {
      std::istringstream pids(read_text(dir_ + "/pids"));
      std::string name;
      pid_t pid = -1;
      while (pids >> name >> pid) {
        if (name == "proxy") proxy_pid_ = pid;
      }
      if (proxy_pid_ > 0) break;
      error = "no proxy pid in " + dir_ + "/pids\n" + r.output;
    } else {
      error = tail(r.output, 80);
    }
    run_stop(dir_);
    std::error_code ec;
    fs::remove_all(dir_, ec);
    dir_.clear();
    const bool port_taken = r.output.find("Could not bind") != std::string::npos ||
                            r.output.find("Address already in use") != std::string::npos;
    if (!port_taken) break;
  }
  ::close(watch[0]);
  if (dir_.empty()) {
    ::close(watch_fd_);
    throw std::runtime_error("SwiftS3: the S3 server (tests/support/swift_s3/start.sh) did not start:\n" + error);
  }
  endpoint_ = "http://127.0.0.1:" + std::to_string(port_);
  start_seconds_ = std::chrono::duration<double>(Clock::now() - t0).count();
}

SwiftS3::~SwiftS3() { stop(); }

void SwiftS3::stop() {
  if (dir_.empty() || ::getpid() != owner_pid_) return;  // a forked child (death test) stops nothing
  // The watchdog stops the server once the pipe's last write end is closed: the path a killed
  // test process takes, so every run exercises it. Should a forked child still hold the pipe,
  // stop.sh is run directly.
  ::close(watch_fd_);
  watch_fd_ = -1;
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  std::error_code ec;
  while (fs::exists(dir_, ec) && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  if (fs::exists(dir_, ec)) run_stop(dir_);
  dir_.clear();
}

std::string SwiftS3::new_bucket(const std::string& hint) {
  const std::string name = dns_safe(hint) + "-" + std::to_string(::getpid()) + "-" + std::to_string(++buckets_);
  const CurlResponse r = curl_request("PUT", endpoint_ + "/" + name, true, 30000);
  if (r.status != 200) {
    throw std::runtime_error("SwiftS3: PUT bucket " + name + " answered " +
                             (r.status ? std::to_string(r.status) + ": " + r.body : r.error));
  }
  return name;
}

std::vector<std::pair<std::string, std::string>> SwiftS3::environment() const {
  return {{"AWS_ACCESS_KEY_ID", kAccessKey},
          {"AWS_SECRET_ACCESS_KEY", kSecretKey},
          {"AWS_REGION", kRegion},
          {"AWS_ENDPOINT_URL_S3", endpoint_}};
}

namespace {

// PID is the proxy this fixture started (its command line names our folder), not a process that
// took its pid after it died.
void check_ours(pid_t pid, const std::string& dir) {
  const std::string cmdline = read_text("/proc/" + std::to_string(pid) + "/cmdline");
  if (cmdline.find(dir + "/etc/proxy-server.conf") == std::string::npos) {
    throw std::runtime_error("SwiftS3: the proxy (pid " + std::to_string(pid) + ") is gone; its log:\n" +
                             tail(read_text(dir + "/log/proxy.log"), 30));
  }
}

void wait_for_state(pid_t pid, bool stopped, const char* what) {
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while ((process_state(pid) == 'T') != stopped) {
    if (Clock::now() > deadline) throw std::runtime_error(std::string("SwiftS3: the proxy did not ") + what);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

}  // namespace

void SwiftS3::pause() {
  check_ours(proxy_pid_, dir_);
  ::kill(proxy_pid_, SIGSTOP);
  wait_for_state(proxy_pid_, true, "stop");
}

void SwiftS3::resume() {
  check_ours(proxy_pid_, dir_);
  ::kill(proxy_pid_, SIGCONT);
  wait_for_state(proxy_pid_, false, "continue");
}

bool SwiftS3::healthy() const { return curl_request("GET", endpoint_ + "/healthcheck", false, 1000).status == 200; }

}  // namespace zoomwarp::test
