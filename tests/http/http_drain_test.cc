// Graceful drain under load: clients keep requesting views (each a warp and an encode, a few
// milliseconds) on keep-alive connections while the server gets SIGTERM with --drain-delay 1.
// Readiness must fail at once while requests are still answered; every request on a connection
// the server accepted must get a whole 2xx (no reset, no truncated body, no connection closed under
// a request); once the listener closes new connections are refused, which is fine and counted
// apart; and the process exits 0.
//
// One more case is counted apart, and only when proven: a connection the kernel completed in the
// microseconds between the server's last accept() and the close of its listener is reset by the
// kernel (every server has that window; zoomwarp accepts what is queued before closing). The
// clients count their connections and the server logs how many it accepted: a reset before any
// byte of an answer, on a new connection, passes only if that many connections were never accepted.
//
// (Ops.SigtermDrainsInFlightRequests covers a few slow requests in flight at the signal; this one
// covers a steady stream of short ones arriving before, at and after it, on reused and new
// connections.)
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <thread>

#include "tests/support/http_client.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using Clock = std::chrono::steady_clock;

// What became of one request. Anything but kOk and kRefused is a failure a client would see.
enum class Outcome {
  kOk,                // a complete 2xx with a valid body
  kRefused,           // connect() refused: the listener is closed
  kBadStatus,         // a complete answer, but not 2xx
  kBadBody,           // a complete 2xx whose body is not a valid JPEG / mesh JSON
  kNoResponse,        // connected and sent, then closed before any byte of an answer
  kResetNoResponse,   // connected and sent, then reset before any byte of an answer
  kTruncated,         // part of an answer, then reset or closed
  kTimeout,           // no complete answer within the time limit
  kOtherError,
};
const char* name(Outcome o) {
  static const char* names[] = {"ok",          "refused",   "bad status", "bad body", "no response",
                                "reset, no response", "truncated", "timeout",    "other"};
  return names[int(o)];
}

// A minimal HTTP/1.1 client on POSIX sockets that tells these cases apart (a library client would
// fold them into one exception). One keep-alive connection, reopened when the server said
// "Connection: close".
class ProbeClient {
 public:
  explicit ProbeClient(int port) : port_(port) {}
  ~ProbeClient() { close_fd(); }

  struct Result {
    Outcome outcome = Outcome::kOtherError;
    bool reused = false;  // sent on a connection that had already carried a request
    int status = 0;
    std::string detail;
  };

  Result get(const std::string& target, bool expect_jpeg) {
    Result r;
    if (fd_ < 0) {
      const int e = open_connection();
      if (e == ECONNREFUSED) return {Outcome::kRefused, false, 0, "refused"};
      if (e != 0) return {Outcome::kOtherError, false, 0, std::string("connect: ") + std::strerror(e)};
    }
    r.reused = used_;
    used_ = true;
    const std::string req = "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port_) + "\r\n\r\n";
    if (::send(fd_, req.data(), req.size(), MSG_NOSIGNAL) != ssize_t(req.size())) {
      r.outcome = errno == ECONNRESET || errno == EPIPE ? Outcome::kResetNoResponse : Outcome::kNoResponse;
      r.detail = std::string("send: ") + std::strerror(errno);
      close_fd();
      return r;
    }
    std::string in;
    std::size_t header_end = std::string::npos, content_length = 0;
    bool close_after = false;
    const auto deadline = Clock::now() + std::chrono::seconds(20);
    while (true) {
      if (header_end != std::string::npos && in.size() >= header_end + content_length) break;
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      pollfd p{fd_, POLLIN, 0};
      if (left <= 0 || ::poll(&p, 1, int(left)) <= 0) {
        r.outcome = Outcome::kTimeout;
        close_fd();
        return r;
      }
      char buf[64 * 1024];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) {
        const bool reset = n < 0 && errno == ECONNRESET;
        r.outcome = !in.empty() ? Outcome::kTruncated : reset ? Outcome::kResetNoResponse : Outcome::kNoResponse;
        r.detail = n == 0 ? "closed by the server" : std::string("recv: ") + std::strerror(errno);
        r.detail += " after " + std::to_string(in.size()) + " bytes";
        close_fd();
        return r;
      }
      in.append(buf, std::size_t(n));
      if (header_end == std::string::npos && (header_end = in.find("\r\n\r\n")) != std::string::npos) {
        header_end += 4;
        const std::string head = lower(in.substr(0, header_end));
        r.status = std::atoi(head.c_str() + head.find(' ') + 1);
        const auto cl = head.find("\r\ncontent-length:");
        content_length = cl == std::string::npos ? 0 : std::strtoull(head.c_str() + cl + 17, nullptr, 10);
        close_after = head.find("\r\nconnection: close") != std::string::npos;
      }
    }
    if (close_after) close_fd();
    const std::string body = in.substr(header_end, content_length);
    if (r.status < 200 || r.status > 299) {
      r.outcome = Outcome::kBadStatus;
      r.detail = body.substr(0, 200);
    } else if (expect_jpeg ? !(body.size() > 4 && body.compare(0, 3, "\xff\xd8\xff") == 0 && body.compare(body.size() - 2, 2, "\xff\xd9") == 0)
                           : !nlohmann::json::parse(body, nullptr, false).is_object()) {
      r.outcome = Outcome::kBadBody;
    } else {
      r.outcome = Outcome::kOk;
    }
    return r;
  }

 private:
  static std::string lower(std::string s) {
    for (auto& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
  }
  int open_connection() {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(std::uint16_t(port_));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      const int e = errno;
      close_fd();
      return e;
    }
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    used_ = false;
    ++connections_;
    return 0;
  }
  void close_fd() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  int port_;
  int fd_ = -1;
  bool used_ = false;

 public:
  int connections_ = 0;  // connect() calls that succeeded
};

// A distinct view per request (so each one is computed, not a cache hit): mesh JSON or viewport JPEG.
std::string view_target(int client, int k, bool viewport) {
  static const char* zooms[] = {"0.3", "0.45", "0.6", "0.75", "0.9"};
  const int n = client * 100003 + k;
  return std::string("/v1/images/boats/") + (viewport ? "viewport" : "mesh") + "?zoom=" + zooms[n % 5] +
         "&cx=" + std::to_string(200 + (n * 53) % 2100) + "&cy=" + std::to_string(200 + (n * 31) % 1200) +
         "&w=480&h=360&method=icaz" + (viewport ? "&format=jpg" : "");
}

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

TEST(Drain, SigtermUnderLoadAnswersEveryAcceptedRequestInFull) {
  testing::TempDir dir;
  const std::string store = dir.path() + "/store";
  auto ingest = testing::run_command({testing::zoomwarp_binary(), "ingest", testing::samples_dir() + "/boats_lake_sunset.jpg",
                                      "--store", store, "--id", "boats", "--quiet"});
  ASSERT_EQ(ingest.exit_code, 0) << ingest.output;
  testing::ServerProcess server(store, {"--drain-delay", "1", "--log-requests", "0"});
  const int port = server.port();

  constexpr int kClients = 6;
  std::atomic<bool> signalled{false}, stop{false};
  std::atomic<int> ok_before{0}, ok_after{0};
  Clock::time_point sigterm_at;  // written before `signalled` is set
  struct Tally {
    int refused = 0, resets_on_new = 0, connections = 0;
    Clock::time_point last_ok;
    std::vector<std::string> failures, resets_on_new_details;
  };
  std::vector<Tally> tallies(kClients);
  std::vector<std::thread> clients;
  struct JoinAll {  // also when an assertion returns early
    std::atomic<bool>& stop;
    std::vector<std::thread>& threads;
    ~JoinAll() {
      stop = true;
      for (auto& t : threads)
        if (t.joinable()) t.join();
    }
  } join_all{stop, clients};
  for (int c = 0; c < kClients; ++c)
    clients.emplace_back([&, c] {
      ProbeClient http(port);
      Tally& t = tallies[c];
      for (int k = 0; !stop; ++k) {
        const bool viewport = k % 2 == 1;
        const bool after_signal = signalled.load();
        const auto r = http.get(view_target(c, k, viewport), viewport);
        if (r.outcome == Outcome::kOk) {
          if (after_signal) ++ok_after, t.last_ok = Clock::now();
          else ++ok_before;
        } else if (r.outcome == Outcome::kRefused) {
          ++t.refused;
          if (signalled) break;  // the listener is closed: this client is done
          std::this_thread::sleep_for(std::chrono::milliseconds(10));
        } else {
          const std::string what = std::string(name(r.outcome)) + (r.reused ? " (reused connection)" : " (new connection)") +
                                   (after_signal ? " after" : " before") + " SIGTERM, status " +
                                   std::to_string(r.status) + ": " + r.detail;
          if (r.outcome == Outcome::kResetNoResponse && !r.reused && after_signal) {
            ++t.resets_on_new;  // maybe never accepted: checked against the server's count below
            t.resets_on_new_details.push_back(what);
          } else {
            t.failures.push_back(what);
          }
        }
      }
      t.connections = http.connections_;
    });

  // Load first: every client has been answered a few times.
  const auto load_deadline = Clock::now() + std::chrono::seconds(30);
  while (ok_before < kClients * 5 && Clock::now() < load_deadline) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GE(ok_before.load(), kClients * 5) << "the load never got going";

  sigterm_at = Clock::now();
  signalled = true;
  ASSERT_EQ(::kill(server.pid(), SIGTERM), 0);

  // Readiness fails at once (a fresh connection each time: a draining server closes after answering).
  std::optional<Clock::time_point> not_ready_at;
  std::string readyz_seen;
  int readyz_connections = 0;
  while (!not_ready_at && Clock::now() - sigterm_at < std::chrono::seconds(1)) {
    ProbeClient probe(port);
    const auto r = probe.get("/readyz", false);
    readyz_connections += probe.connections_;
    readyz_seen += std::string(" ") + name(r.outcome) + " " + std::to_string(r.status);
    if (r.status == 503) not_ready_at = Clock::now();
    if (r.outcome != Outcome::kOk && r.outcome != Outcome::kBadStatus) break;  // too late
  }
  ASSERT_TRUE(not_ready_at) << "/readyz did not answer 503 within the 1 s drain delay:" << readyz_seen;
  EXPECT_LT(ms_between(sigterm_at, *not_ready_at), 500);
  const int ok_when_not_ready = ok_after.load();

  // The process exits by itself: SIGTERM again (what terminate() sends) changes nothing while it drains.
  const int exit_code = server.terminate(30);
  const auto exited_at = Clock::now();
  stop = true;
  for (auto& t : clients) t.join();

  int refused = 0, failures = 0, resets_on_new = 0, connections = readyz_connections;
  Clock::time_point last_ok = sigterm_at;
  std::string reset_details;
  for (const auto& t : tallies) {
    refused += t.refused;
    failures += int(t.failures.size());
    resets_on_new += t.resets_on_new;
    connections += t.connections;
    last_ok = std::max(last_ok, t.last_ok);
    for (const auto& d : t.failures) ADD_FAILURE() << d;
    for (const auto& d : t.resets_on_new_details) reset_details += "\n  " + d;
  }
  // How many of the clients' connections the server accepted, from its last log line.
  std::smatch m;
  const std::string log = server.log();
  ASSERT_TRUE(std::regex_search(log, m, std::regex(R"re("connections_accepted":(\d+))re"))) << log;
  const int never_accepted = connections - std::stoi(m[1]);
  std::printf("[ figures ] %d clients: %d requests answered before SIGTERM, %d after it (the last %.0f ms after it), "
              "%d failed; /readyz 503 %.1f ms after SIGTERM; %d connections refused once the listener closed, "
              "%d reset when it closed (%d of %d connections never accepted); exit %d %.0f ms after SIGTERM\n",
              kClients, ok_before.load(), ok_after.load(), ms_between(sigterm_at, last_ok), failures,
              ms_between(sigterm_at, *not_ready_at), refused, resets_on_new, never_accepted, connections, exit_code,
              ms_between(sigterm_at, exited_at));
  EXPECT_EQ(failures, 0) << "every request that was accepted is answered in full with a 2xx";
  EXPECT_LE(resets_on_new, never_accepted)
      << "a reset on a connection the server had accepted, not one the kernel reset as the listener closed:"
      << reset_details;
  EXPECT_GE(never_accepted, 0);
  EXPECT_EQ(exit_code, 0);
  EXPECT_GT(ok_after.load(), ok_when_not_ready) << "requests are still answered after /readyz went 503";
  EXPECT_GE(ms_between(sigterm_at, last_ok), 800) << "the listener stays open for the 1 s drain delay";
  EXPECT_GE(refused, 1) << "once the listener closed, new connections are refused";
  EXPECT_LT(ms_between(sigterm_at, exited_at), 5000) << "no request keeps the drain waiting";
}

}  // namespace
}  // namespace zoomwarp
