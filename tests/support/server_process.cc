#include "tests/support/server_process.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace zoomwarp::testing {

namespace fs = std::filesystem;

std::string zoomwarp_binary() { return ZOOMWARP_BINARY; }
std::string zoomwarp_poisonable_binary() { return ZOOMWARP_POISONABLE_BINARY; }
std::string samples_dir() { return ZOOMWARP_SAMPLES; }

TempDir::TempDir() {
  const char* base = std::getenv("TMPDIR");
  std::random_device rd;
  path_ = (fs::path(base && *base ? base : "/tmp") /
           ("zoomwarp-test-" + std::to_string(::getpid()) + "-" + std::to_string(rd())))
              .string();
  fs::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

namespace {

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// `env` is added to the test's own environment; it is made before the fork (the child of a
// threaded process may only call async-signal-safe functions).
pid_t spawn(const std::vector<std::string>& argv, const std::string& output_path,
            const std::vector<std::pair<std::string, std::string>>& env = {}) {
  std::vector<std::string> environment;
  for (char** e = environ; *e; ++e) environment.emplace_back(*e);
  for (const auto& [name, value] : env) environment.push_back(name + "=" + value);
  std::vector<char*> envp;
  for (auto& e : environment) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    int fd = ::open(output_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
      ::close(fd);
    }
    ::execve(args[0], args.data(), envp.data());
    ::_exit(127);
  }
  return pid;
}

}  // namespace

ServerProcess::ServerProcess(const std::string& store, const std::vector<std::string>& extra_args, Writes writes,
                             const ServerExecutable& executable) {
  static int counter = 0;
  // Next to a folder store; a bucket's (s3://…) goes to the temporary folder.
  const std::string log_base = store.starts_with("s3://") ? (fs::temp_directory_path() / "zoomwarp").string() : store;
  log_path_ = log_base + ".server-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".log";
  // A first view computes the image's analysis for its method (issue 28), seconds on a loaded CI
  // machine: tests about views get a deadline that no test machine reaches; tests about deadlines
  // set their own (a later option wins).
  std::vector<std::string> argv = {executable.path, "serve", "--host", "127.0.0.1", "--port", "0",
                                   "--store", store, "--request-timeout", "120"};
  argv.insert(argv.end(), extra_args.begin(), extra_args.end());
  const bool has_keys = std::find(extra_args.begin(), extra_args.end(), "--keys") != extra_args.end();
  if (writes == Writes::kOpen && !has_keys) argv.push_back("--open-writes");
  pid_ = spawn(argv, log_path_, executable.env);
  const std::regex listening(R"re("msg":"listening".*"port":(\d+))re");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    std::smatch m;
    const std::string text = read_all(log_path_);
    if (std::regex_search(text, m, listening)) {
      port_ = std::stoi(m[1]);
      return;
    }
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      throw std::runtime_error("zoomwarp serve exited at start:\n" + text);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  terminate(1);
  throw std::runtime_error("zoomwarp serve did not start listening:\n" + read_all(log_path_));
}

ServerProcess::~ServerProcess() {
  terminate(10);
  std::error_code ec;
  fs::remove(log_path_, ec);
}

int ServerProcess::terminate(double timeout_s) {
  if (pid_ <= 0) return -1;
  ::kill(pid_, SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ::kill(pid_, SIGKILL);
  ::waitpid(pid_, &status, 0);
  pid_ = -1;
  return -1;
}

int ServerProcess::wait_for_end(double timeout_s) {
  if (pid_ <= 0) return -1;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (::waitpid(pid_, &status, WNOHANG) != pid_) {
    if (std::chrono::steady_clock::now() > deadline) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  pid_ = -1;
  return WIFSIGNALED(status) ? WTERMSIG(status) : 0;
}

std::string ServerProcess::log() const { return read_all(log_path_); }

bool ServerProcess::wait_for_log(const std::string& needle, double seconds) const {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (log().find(needle) == std::string::npos) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

int unused_loopback_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

std::string read_file(const std::string& path) { return read_all(path); }

RunResult run_command(const std::vector<std::string>& argv) {
  TempDir dir;
  const std::string out = dir.path() + "/output";
  pid_t pid = spawn(argv, out);
  int status = 0;
  struct rusage usage {};
  ::wait4(pid, &status, 0, &usage);
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.output = read_all(out);
  r.max_rss_kb = usage.ru_maxrss;
  return r;
}

pid_t spawn_quietly(const std::vector<std::string>& argv) { return spawn(argv, "/dev/null"); }

}  // namespace zoomwarp::testing
