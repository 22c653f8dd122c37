// Uploads and connections against a real server: slow headers and stalled bodies are dropped and
// leave nothing behind; uploads beyond the ingest capacity, in no accepted format, with an
// unreadable header or over the pixel limit are refused from their first bytes, before their
// body is read; the connection cap and file descriptor exhaustion make the listener wait, not
// spin or flood the log.
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "tests/http/raw_connection.h"
#include "tests/support/http_client.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HttpClient;
using testing::RawConnection;
using testing::ServerProcess;
using testing::TempDir;
using namespace std::chrono_literals;

std::string sample(const std::string& name) { return testing::read_file(testing::samples_dir() + "/" + name); }

// A bound on each wait for the server, for the test's own sake, not an assertion about speed.
constexpr int kWaitMs = 30'000;

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

  RawConnection stalled(server.port());
  ASSERT_TRUE(stalled.try_send(upload_head("stalled", png.size()) + png.substr(0, 150'000)));
  ASSERT_EQ(wait_for_staging(store, 1), 1u) << "the body's first bytes are being staged";
  const auto r = stalled.read_until_close(kWaitMs);
  EXPECT_TRUE(r.closed) << "a body that stops arriving is dropped after --body-timeout";
  EXPECT_EQ(wait_for_staging(store, 0), 0u) << "and its staging folder removed";

  HttpClient http(server.port());
  EXPECT_EQ(http.request("POST", "/v1/images?id=whole", png).status, 201);
  EXPECT_EQ(http.get("/v1/images/stalled").status, 404);
}

TEST(UploadLimits, SlowHeaderIsDroppedButAnIdleConnectionIsNot) {
  TempDir dir;
  ServerProcess server(dir.path() + "/store", {"--header-timeout", "1", "--idle-timeout", "3600"});
  RawConnection idle(server.port());
  RawConnection dripping(server.port());
  ASSERT_TRUE(dripping.try_send("GET /healthz HTTP/1.1\r\nHost: te"));
  const auto r = dripping.read_until_close(kWaitMs);
  EXPECT_TRUE(r.closed) << "a header not finished within --header-timeout of its first byte";
  EXPECT_EQ(r.bytes, "");

  // The connection that has sent nothing yet waits under the idle timeout, not the header's.
  ASSERT_TRUE(idle.try_send("GET /healthz HTTP/1.1\r\nHost: test\r\n\r\n"));
  EXPECT_EQ(status_of(idle.read_response(kWaitMs)), 200);
}

TEST(UploadLimits, UploadsBeyondIngestCapacityAreRefusedAfterTheirHeader) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  ServerProcess server(store, {"--ingest-workers", "1", "--ingest-queue", "1"});
  const std::string png = sample("astronaut_portrait.png");

  // Two uploads take both slots (one ingest thread, one queue place) and pause mid-body.
  std::vector<std::unique_ptr<RawConnection>> holding;
  for (const char* id : {"first", "second"}) {
    holding.push_back(std::make_unique<RawConnection>(server.port()));
    ASSERT_TRUE(holding.back()->try_send(upload_head(id, png.size()) + png.substr(0, 100'000)));
  }
  ASSERT_EQ(wait_for_staging(store, 2), 2u);

  // More uploads: 503 with Retry-After after the header alone (no body was sent), connection closed.
  for (int i = 0; i < 5; ++i) {
    RawConnection extra(server.port());
    ASSERT_TRUE(extra.try_send(upload_head("extra" + std::to_string(i), png.size())));
    const auto r = extra.read_until_close(kWaitMs);
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(status_of(r.bytes), 503) << r.bytes;
    EXPECT_NE(r.bytes.find("\r\nRetry-After: 1\r\n"), std::string::npos) << r.bytes;
    EXPECT_NE(r.bytes.find("\r\nConnection: close\r\n"), std::string::npos) << r.bytes;
    EXPECT_EQ(error_code_of(r.bytes), "ingest_busy") << r.bytes;
    EXPECT_EQ(entries(store + "/staging"), 2u) << "nothing staged for a refused upload";
  }

  for (auto& c : holding) ASSERT_TRUE(c->try_send(png.substr(100'000)));
  for (auto& c : holding) EXPECT_EQ(status_of(c->read_response(kWaitMs)), 201);
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

  RawConnection first(server.port());
  ASSERT_TRUE(first.try_send(upload_head("first", png.size()) + png.substr(0, 100'000)));
  ASSERT_EQ(wait_for_staging(store, 1), 1u);
  RawConnection second(server.port());
  ASSERT_TRUE(second.try_send(upload_head("second", png.size())));
  const auto refused = second.read_until_close(kWaitMs);
  EXPECT_EQ(status_of(refused.bytes), 503) << refused.bytes;
  EXPECT_EQ(error_code_of(refused.bytes), "ingest_busy");
  EXPECT_TRUE(refused.closed);

  ASSERT_TRUE(first.try_send(png.substr(100'000)));
  EXPECT_EQ(status_of(first.read_response(kWaitMs)), 201);
  HttpClient http(server.port());
  EXPECT_EQ(http.request("POST", "/v1/images?id=second", png).status, 201) << "the bytes are free again";
}

// Sends the head of a `declared`-byte upload, then `first` and up to 1 MiB of filler, and returns
// what the server answered and whether it then closed the connection.
RawConnection::Received refused_upload(int port, std::uint64_t declared, const std::string& first, char filler) {
  RawConnection c(port);
  c.try_send(upload_head("x", declared) + first);  // the server may refuse and close before all of it
  const std::string chunk(64 * 1024, filler);
  for (int i = 0; i < 16 && !c.readable(0); ++i)
    if (!c.try_send(chunk)) break;
  return c.read_until_close(kWaitMs);
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
  auto first = std::make_unique<RawConnection>(server.port());
  RawConnection second(server.port());
  ASSERT_TRUE(first->try_send(get));
  ASSERT_TRUE(second.try_send(get));
  EXPECT_EQ(status_of(first->read_response(kWaitMs)), 200);
  EXPECT_EQ(status_of(second.read_response(kWaitMs)), 200);

  RawConnection third(server.port(), std::nothrow);  // completed by the kernel, not accepted while two are open
  ASSERT_TRUE(third.connected());
  ASSERT_TRUE(third.try_send(get));
  EXPECT_FALSE(third.readable(500)) << "a third connection was served beyond --max-connections 2";
  first.reset();
  EXPECT_EQ(status_of(third.read_response(kWaitMs)), 200);
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
  std::vector<std::unique_ptr<RawConnection>> clients;
  for (int i = 0; i < 30; ++i) {
    clients.push_back(std::make_unique<RawConnection>(server.port(), std::nothrow));
    ASSERT_TRUE(clients.back()->connected());
    ASSERT_TRUE(clients.back()->try_send(get));
  }
  std::this_thread::sleep_for(3s);  // the listener at EMFILE for a while
  const std::string log = server.log();
  std::size_t failures = 0;
  for (auto at = log.find("accept failed"); at != std::string::npos; at = log.find("accept failed", at + 1)) ++failures;
  EXPECT_GE(failures, 1u) << "the limit was reached";
  EXPECT_LE(failures, 8u) << "at most one log line a second, not one per failed accept";

  // Every client is answered as the ones before it close: the listener takes them up again.
  for (auto& c : clients) {
    EXPECT_EQ(status_of(c->read_response(kWaitMs)), 200);
    c.reset();
  }
  HttpClient http(server.port());
  EXPECT_EQ(http.get("/healthz").status, 200);
}

}  // namespace
}  // namespace zoomwarp
