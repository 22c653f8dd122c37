// Runs the real `zoomwarp serve` binary as a child process on a loopback port it picks itself,
// for tests that talk HTTP to it. The destructor stops it (SIGTERM, then SIGKILL), so no test
// leaves a server behind.
#pragma once

#include <sys/types.h>

#include <string>
#include <utility>
#include <vector>

namespace zoomwarp::testing {

// Path of the zoomwarp binary under test and of the bundled sample images.
std::string zoomwarp_binary();
// The same server with the test compute hook (tests/support/compute_hook_poison.cc), never shipped.
std::string zoomwarp_poisonable_binary();
std::string samples_dir();

// A fresh empty folder under the test's temporary directory, removed by its destructor.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// The server executable to run (another build of it: zoomwarp_poisonable_binary()) and environment
// variables it gets besides the test's own.
struct ServerExecutable {
  std::string path = zoomwarp_binary();
  std::vector<std::pair<std::string, std::string>> env;
};

class ServerProcess {
 public:
  // Tests that are not about access write freely: by default the server gets --open-writes
  // (anyone may upload, delete and edit), unless ARGS hold --keys (then keys govern writes).
  // kAsConfigured passes ARGS alone: the server's own default, which refuses writes without keys.
  enum class Writes { kOpen, kAsConfigured };

  // Starts `zoomwarp serve --host 127.0.0.1 --port 0 --store STORE ARGS...` (and --open-writes,
  // see Writes) and waits for its "listening" log line. Throws std::runtime_error if it does not
  // come up within 20 s, or exits first (the message holds its log).
  ServerProcess(const std::string& store, const std::vector<std::string>& extra_args = {},
                Writes writes = Writes::kOpen, const ServerExecutable& executable = {});
  ~ServerProcess();
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  int port() const { return port_; }
  pid_t pid() const { return pid_; }

  // Sends SIGTERM and waits (up to `timeout_s`); returns the exit status, or -1 if it had to be
  // killed.
  int terminate(double timeout_s = 20);

  // Waits up to `timeout_s` for the process to end by itself: the signal that ended it, 0 if it
  // exited, -1 if it still runs.
  int wait_for_end(double timeout_s);

  // Everything the server has logged so far (JSON lines).
  std::string log() const;

  // Waits until the log holds `needle`; false if it has not after `seconds` (a bound on a hang).
  // For lines written after the response is sent (a request's own lines come once it is written).
  bool wait_for_log(const std::string& needle, double seconds = 10) const;

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  std::string log_path_;
};

std::string read_file(const std::string& path);

// A loopback port nothing listens on (bound and released at once), for "unreachable" tests.
int unused_loopback_port();

// Runs a command to completion, returns its exit status; stdout/stderr go to `output` if given.
struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr, interleaved
  long max_rss_kb = 0; // peak resident set size of the child
};
RunResult run_command(const std::vector<std::string>& argv);

// Starts a command without waiting for it, its output to /dev/null; the caller reaps it (waitpid).
pid_t spawn_quietly(const std::vector<std::string>& argv);

}  // namespace zoomwarp::testing
