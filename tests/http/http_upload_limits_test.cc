// Uploads and connections against a real server: slow headers and stalled bodies are dropped and
// leave nothing behind; uploads beyond the ingest capacity, in no accepted format, with an
// unreadable header or over the pixel limit are refused from their first bytes, before their
// body is read; the connection cap and file descriptor exhaustion make the listener wait, not
// spin or flood the log.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/http_client.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HttpClient;
using testing::ServerProcess;
using testing::TempDir;
using namespace std::chrono_literals;

std::string sample(const std::string& name) { return testing::read_file(testing::samples_dir() + "/" + name); }

// One raw TCP connection to the server (plain POSIX: a test must control every byte and pause).
class Connection {
 public:
  explicit Connection(int port) : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  }
  ~Connection() { ::close(fd_); }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  bool connected() const { return connected_; }

  // False once the server has closed (or reset) the connection.
  bool send(const std::string& bytes) {
    return ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL) == ssize_t(bytes.size());
  }

  // Whether something (bytes or the end of the stream) arrives within `timeout`.
  bool readable(std::chrono::milliseconds timeout) {
    pollfd p{fd_, POLLIN, 0};
    return ::poll(&p, 1, int(timeout.count())) > 0;
  }

  // What arrives until the server closes the connection; `closed` is false if it had not within
  // `timeout` (a bound for the test's own sake, not an assertion about speed).
  struct Received {
    std::string bytes;
    bool closed = false;
  };
  Received read_until_closed(std::chrono::milliseconds timeout = 30s) {
    Received r;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    char buf[16384];
    while (true) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0 || !readable(left)) return r;
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) {
        r.closed = true;
        return r;
      }
      r.bytes.append(buf, std::size_t(n));
    }
  }

  // One response's head and body (Content-Length framed), leaving the connection open.
  std::string read_response(std::chrono::milliseconds timeout = 30s) {
    std::string out;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    char buf[16384];
    while (!complete(out)) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0 || !readable(left)) break;
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) break;
      out.append(buf, std::size_t(n));
    }
    return out;
  }

 private:
  static bool complete(const std::string& r) {
    const auto end = r.find("\r\n\r\n");
    if (end == std::string::npos) return false;
    const auto cl = r.find("Content-Length: ");
    const std::size_t length = cl < end ? std::stoul(r.substr(cl + 16)) : 0;
    return r.size() >= end + 4 + length;
  }

  int fd_;
  bool connected_ = false;
};

int status_of(const std::string& response) {
  return response.rfind("HTTP/1.1 ", 0) == 0 ? std::stoi(response.substr(9, 3)) : 0;
}

std::string error_code_of(const std::string& response) {
  const auto body = response.find("\r\n\r\n");
  if (body == std::string::npos) return "";
  auto j = json::parse(response.substr(body + 4), nullptr, false);
  return j.is_object() && j.contains("error") ? j["error"].value("code", "") : "";
}

std::string upload_head(const std::string& id, std::uint64_t length) {
  return "POST /v1/images?id=" + id + " HTTP/1.1\r\nHost: test\r\nContent-Length: " + std::to_string(length) + "\r\n\r\n";
}

std::size_t entries(const std::string& folder) {
  std::error_code ec;
  std::size_t n = 0;
  for (auto it = fs::directory_iterator(folder, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) ++n;
  return n;
}

// Polls until the store's staging folder holds `n` entries (or 20 s passed); returns the count.
std::size_t wait_for_staging(const std::string& store, std::size_t n) {
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (entries(store + "/staging") != n && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(20ms);
  return entries(store + "/staging");
}

TEST(UploadLimits, StalledBodyIsDroppedAndItsStagingFileRemoved) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  ServerProcess server(store, {"--body-timeout", "1", "--idle-timeout", "3600"});
  const std::string png = sample("astronaut_portrait.png");
  ASSERT_GT(png.size(), 200'000u);

  Connection stalled(server.port());
  ASSERT_TRUE(stalled.send(upload_head("stalled", png.size()) + png.substr(0, 150'000)));
  ASSERT_EQ(wait_for_staging(store, 1), 1u) << "the body's first bytes are being staged";
  const auto r = stalled.read_until_closed();
  EXPECT_TRUE(r.closed) << "a body that stops arriving is dropped after --body-timeout";
  EXPECT_EQ(wait_for_staging(store, 0), 0u) << "and its staging folder removed";

  HttpClient http(server.port());
  EXPECT_EQ(http.request("POST", "/v1/images?id=whole", png).status, 201);
  EXPECT_EQ(http.get("/v1/images/stalled").status, 404);
}

TEST(UploadLimits, SlowHeaderIsDroppedButAnIdleConnectionIsNot) {
  TempDir dir;
  ServerProcess server(dir.path() + "/store", {"--header-timeout", "1", "--idle-timeout", "3600"});
  Connection idle(server.port());
  Connection dripping(server.port());
  ASSERT_TRUE(dripping.send("GET /healthz HTTP/1.1\r\nHost: te"));
  const auto r = dripping.read_until_closed();
  EXPECT_TRUE(r.closed) << "a header not finished within --header-timeout of its first byte";
  EXPECT_EQ(r.bytes, "");

  // The connection that has sent nothing yet waits under the idle timeout, not the header's.
  ASSERT_TRUE(idle.send("GET /healthz HTTP/1.1\r\nHost: test\r\n\r\n"));
  EXPECT_EQ(status_of(idle.read_response()), 200);
}

TEST(UploadLimits, UploadsBeyondIngestCapacityAreRefusedAfterTheirHeader) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  ServerProcess server(store, {"--ingest-workers", "1", "--ingest-queue", "1"});
  const std::string png = sample("astronaut_portrait.png");

  // Two uploads take both slots (one ingest thread, one queue place) and pause mid-body.
  std::vector<std::unique_ptr<Connection>> holding;
  for (const char* id : {"first", "second"}) {
    holding.push_back(std::make_unique<Connection>(server.port()));
    ASSERT_TRUE(holding.back()->send(upload_head(id, png.size()) + png.substr(0, 100'000)));
  }
  ASSERT_EQ(wait_for_staging(store, 2), 2u);

  // More uploads: 503 with Retry-After after the header alone (no body was sent), connection closed.
  for (int i = 0; i < 5; ++i) {
    Connection extra(server.port());
    ASSERT_TRUE(extra.send(upload_head("extra" + std::to_string(i), png.size())));
    const auto r = extra.read_until_closed();
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(status_of(r.bytes), 503) << r.bytes;
    EXPECT_NE(r.bytes.find("\r\nRetry-After: 1\r\n"), std::string::npos) << r.bytes;
    EXPECT_NE(r.bytes.find("\r\nConnection: close\r\n"), std::string::npos) << r.bytes;
    EXPECT_EQ(error_code_of(r.bytes), "ingest_busy") << r.bytes;
    EXPECT_EQ(entries(store + "/staging"), 2u) << "nothing staged for a refused upload";
  }

  for (auto& c : holding) ASSERT_TRUE(c->send(png.substr(100'000)));
  for (auto& c : holding) EXPECT_EQ(status_of(c->read_response()), 201);
  // Their slots are free again.
  HttpClient http(server.port());
  EXPECT_EQ(http.request("POST", "/v1/images?id=third", png).status, 201);
  EXPECT_EQ(http.get("/v1/images/extra0").status, 404);
}

TEST(UploadLimits, BytesStagedAtOnceAreCapped) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  ServerProcess server(store, {"--max-staging", "1M"});
  const std::string png = sample("astronaut_portrait.png");  // 773 KiB: two do not fit in 1 MiB
  ASSERT_GT(png.size(), 512u * 1024);

  Connection first(server.port());
  ASSERT_TRUE(first.send(upload_head("first", png.size()) + png.substr(0, 100'000)));
  ASSERT_EQ(wait_for_staging(store, 1), 1u);
  Connection second(server.port());
  ASSERT_TRUE(second.send(upload_head("second", png.size())));
  const auto refused = second.read_until_closed();
  EXPECT_EQ(status_of(refused.bytes), 503) << refused.bytes;
  EXPECT_EQ(error_code_of(refused.bytes), "ingest_busy");
  EXPECT_TRUE(refused.closed);

  ASSERT_TRUE(first.send(png.substr(100'000)));
  EXPECT_EQ(status_of(first.read_response()), 201);
  HttpClient http(server.port());
  EXPECT_EQ(http.request("POST", "/v1/images?id=second", png).status, 201) << "the bytes are free again";
}

// Sends the head of a `declared`-byte upload, then `first` and up to 1 MiB of filler, and returns
// what the server answered and whether it then closed the connection.
Connection::Received refused_upload(int port, std::uint64_t declared, const std::string& first, char filler) {
  Connection c(port);
  c.send(upload_head("x", declared) + first);
  const std::string chunk(64 * 1024, filler);
  for (int i = 0; i < 16 && !c.readable(0ms); ++i)
    if (!c.send(chunk)) break;
  return c.read_until_closed();
}

TEST(UploadLimits, BadImagesAreRefusedFromTheirFirstBytes) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  ServerProcess server(store, {"--max-pixels", "5000000", "--max-upload", "1G"});
  constexpr std::uint64_t k400MB = 400ull << 20;  // declared; at most ~1 MiB of it is ever sent

  auto junk_jpeg = refused_upload(server.port(), k400MB, "\xFF\xD8\xFF", '\0');
  EXPECT_EQ(status_of(junk_jpeg.bytes), 422) << junk_jpeg.bytes;
  EXPECT_EQ(error_code_of(junk_jpeg.bytes), "corrupt_image");
  EXPECT_TRUE(junk_jpeg.closed);

  auto gif = refused_upload(server.port(), k400MB, "GIF89a", 'x');
  EXPECT_EQ(status_of(gif.bytes), 415) << gif.bytes;
  EXPECT_EQ(error_code_of(gif.bytes), "unsupported_format");
  EXPECT_TRUE(gif.closed);

  // A PNG header declaring 4000 × 4000 (16 MP, over --max-pixels 5000000), CRC intact.
  std::string png = sample("astronaut_portrait.png").substr(0, 100'000);
  const std::string ihdr("\0\0\x0F\xA0\0\0\x0F\xA0\x08\x02\0\0\0", 13);
  png.replace(16, 13, ihdr);
  png.replace(29, 4, std::string("\x61\x1D\x74\x55", 4));  // zlib.crc32(b"IHDR" + ihdr)
  auto huge = refused_upload(server.port(), k400MB, png, '\0');
  EXPECT_EQ(status_of(huge.bytes), 413) << huge.bytes;
  EXPECT_EQ(error_code_of(huge.bytes), "image_too_large");
  EXPECT_TRUE(huge.closed);

  EXPECT_EQ(entries(store + "/staging"), 0u);
  HttpClient http(server.port());
  EXPECT_EQ(http.request("POST", "/v1/images?id=ok", sample("boats_lake_sunset.jpg")).status, 201);
  EXPECT_EQ(json::parse(http.get("/v1/images").body)["images"].size(), 1u);
}

TEST(UploadLimits, ConnectionsOverTheCapWaitForAFreeOne) {
  TempDir dir;
  ServerProcess server(dir.path() + "/store", {"--max-connections", "2", "--idle-timeout", "3600"});
  const std::string get = "GET /healthz HTTP/1.1\r\nHost: test\r\n\r\n";
  auto first = std::make_unique<Connection>(server.port());
  Connection second(server.port());
  ASSERT_TRUE(first->send(get));
  ASSERT_TRUE(second.send(get));
  EXPECT_EQ(status_of(first->read_response()), 200);
  EXPECT_EQ(status_of(second.read_response()), 200);

  Connection third(server.port());  // completed by the kernel, not accepted while two are open
  ASSERT_TRUE(third.connected());
  ASSERT_TRUE(third.send(get));
  EXPECT_FALSE(third.readable(500ms)) << "a third connection was served beyond --max-connections 2";
  first.reset();
  EXPECT_EQ(status_of(third.read_response()), 200);
}

std::size_t open_fds(pid_t pid) { return entries("/proc/" + std::to_string(pid) + "/fd"); }

TEST(UploadLimits, OutOfFileDescriptorsTheServerWaitsAndRecovers) {
  TempDir dir;
  ServerProcess server(dir.path() + "/store", {"--idle-timeout", "3600"});
  // Lower the running server's open-file limit to a few more than it uses (as `ulimit -n` would).
  const rlim_t limit = rlim_t(open_fds(server.pid()) + 6);
  const rlimit low{limit, limit};
  ASSERT_EQ(::prlimit(server.pid(), RLIMIT_NOFILE, &low, nullptr), 0);

  const std::string get = "GET /healthz HTTP/1.1\r\nHost: test\r\n\r\n";
  std::vector<std::unique_ptr<Connection>> clients;
  for (int i = 0; i < 30; ++i) {
    clients.push_back(std::make_unique<Connection>(server.port()));
    ASSERT_TRUE(clients.back()->connected());
    ASSERT_TRUE(clients.back()->send(get));
  }
  std::this_thread::sleep_for(3s);  // the listener at EMFILE for a while
  const std::string log = server.log();
  std::size_t failures = 0;
  for (auto at = log.find("accept failed"); at != std::string::npos; at = log.find("accept failed", at + 1)) ++failures;
  EXPECT_GE(failures, 1u) << "the limit was reached";
  EXPECT_LE(failures, 8u) << "at most one log line a second, not one per failed accept";

  // Every client is answered as the ones before it close: the listener takes them up again.
  for (auto& c : clients) {
    EXPECT_EQ(status_of(c->read_response()), 200);
    c.reset();
  }
  HttpClient http(server.port());
  EXPECT_EQ(http.get("/healthz").status, 200);
}

}  // namespace
}  // namespace zoomwarp
