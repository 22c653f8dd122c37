// Protocol strictness, against the real server: a request refused for framing reasons closes the
// connection (a pipelined request behind it is not answered: no request smuggling behind a proxy);
// error bodies name no file path, host name or process id; If-Match and If-None-Match follow
// RFC 9110 §13.1; a query parameter given twice is a 400 on every route.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/http/raw_connection.h"
#include "tests/support/http_client.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;
using testing::RawConnection;

const std::string kPipelined = "GET /healthz HTTP/1.1\r\nHost: t\r\n\r\n";

class Protocol : public ::testing::Test {
 protected:
  void SetUp() override {
    server_.emplace(store_path(), std::vector<std::string>{"--log-requests", "0"});
    upload();
  }
  std::string store_path() const { return dir_.path() + "/store"; }
  void upload() {
    ASSERT_EQ(HttpClient(server_->port())
                  .request("POST", "/v1/images?id=a", testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg"))
                  .status,
              201);
  }

  testing::TempDir dir_;
  std::optional<testing::ServerProcess> server_;
};

struct FramingCase {
  const char* name;
  std::string request;
  int status;
};

TEST_F(Protocol, AFramingErrorClosesTheConnectionAndThePipelinedRequestIsNotAnswered) {
  const std::string put = "PUT /v1/images/a/lines HTTP/1.1\r\nHost: t\r\n";
  const std::vector<FramingCase> cases = {
      {"gzip transfer coding", put + "Transfer-Encoding: gzip\r\n\r\n", 400},
      {"gzip transfer coding on a GET", "GET /healthz HTTP/1.1\r\nHost: t\r\nTransfer-Encoding: gzip\r\n\r\n", 400},
      {"gzip before chunked", put + "Transfer-Encoding: gzip, chunked\r\n\r\n0\r\n\r\n", 501},
      {"two transfer codings headers", put + "Transfer-Encoding: chunked\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n", 400},
      {"conflicting lengths", put + "Content-Length: 2\r\nContent-Length: 3\r\n\r\n{}x", 400},
      {"length and chunked", put + "Content-Length: 5\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n", 400},
      {"malformed header", "GET /healthz HTTP/1.1\r\nHost: t\r\nNo colon here\r\n\r\n", 400},
      {"bad chunk size", put + "Transfer-Encoding: chunked\r\n\r\nzz\r\n\r\n", 400},
      {"body too large", put + "Content-Length: 99999999\r\n\r\n", 413},
      {"header too large", "GET /healthz HTTP/1.1\r\nHost: t\r\nX-Big: " + std::string(20000, 'a') + "\r\n\r\n", 431},
  };
  for (const auto& c : cases) {
    RawConnection conn(server_->port());
    conn.send(c.request + kPipelined);
    const auto reply = conn.read_until_close(5000);
    EXPECT_TRUE(reply.closed) << c.name << ": the server must close the connection";
    EXPECT_EQ(reply.bytes.rfind("HTTP/1.1 " + std::to_string(c.status) + " ", 0), 0u) << c.name << ": " << reply.bytes.substr(0, 200);
    EXPECT_EQ(testing::count_of(reply.bytes, "HTTP/1.1 "), 1) << c.name << ": the pipelined request was answered";
    EXPECT_NE(reply.bytes.find("\r\nConnection: close\r\n"), std::string::npos) << c.name;
  }
  EXPECT_EQ(HttpClient(server_->port()).get("/healthz").status, 200);
}

// A well-formed pipelined pair is answered in order on one connection (the strictness above
// is about framing, not pipelining).
TEST_F(Protocol, PipelinedRequestsAreAnsweredInOrder) {
  RawConnection conn(server_->port());
  conn.send("GET /v1/images/a/viewport?zoom=0.5&w=64&h=64 HTTP/1.1\r\nHost: t\r\n\r\n" + kPipelined +
            "GET /healthz HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n");
  const auto reply = conn.read_until_close(20000);
  EXPECT_TRUE(reply.closed);
  EXPECT_EQ(testing::count_of(reply.bytes, "HTTP/1.1 200 OK"), 3) << reply.bytes.substr(0, 300);
  EXPECT_LT(reply.bytes.find("image/jpeg"), reply.bytes.find("application/json"));
}

// What a client must not learn from an error: where the store is, the host's name, the pid.
void expect_nothing_private(const std::string& body, const std::string& store, pid_t pid) {
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  EXPECT_EQ(body.find(store), std::string::npos) << body;
  EXPECT_EQ(body.find("/staging"), std::string::npos) << body;
  EXPECT_EQ(body.find("/versions"), std::string::npos) << body;
  EXPECT_EQ(body.find(host), std::string::npos) << body;
  EXPECT_EQ(body.find(std::to_string(pid)), std::string::npos) << body;
}

TEST_F(Protocol, ErrorBodiesNameNoPathHostOrPid) {
  // A corrupt upload: the decoder's message names the staged file.
  std::string junk = testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg").substr(0, 3000);
  auto corrupt = HttpClient(server_->port()).request("POST", "/v1/images?id=b", junk);
  EXPECT_EQ(corrupt.status, 422) << corrupt.body;
  EXPECT_EQ(json::parse(corrupt.body)["error"]["code"], "corrupt_image");
  expect_nothing_private(corrupt.body, store_path(), server_->pid());

  // Tile files broken on disk behind a fresh server (nothing cached): reading them fails.
  ASSERT_EQ(server_->terminate(), 0);
  for (const auto& f : std::filesystem::recursive_directory_iterator(store_path() + "/versions"))
    if (f.path().extension() == ".tif") std::ofstream(f.path(), std::ios::trunc) << "not a TIFF";
  server_.emplace(store_path());
  auto broken = HttpClient(server_->port()).get("/iiif/3/a/full/300,/0/default.jpg");
  EXPECT_EQ(broken.status, 500) << broken.body;
  EXPECT_EQ(json::parse(broken.body)["error"]["code"], "internal_error");
  expect_nothing_private(broken.body, store_path(), server_->pid());
  // The operator gets the detail (logged once the answer is written).
  EXPECT_TRUE(server_->wait_for_log("\"msg\":\"request failed\""));
}

TEST_F(Protocol, IfMatchUsesStrongComparisonAndLists) {
  HttpClient http(server_->port());
  const std::string body = R"({"lines": [[0, 100, 500, 100]]})";
  std::string etag = http.get("/v1/images/a").header("etag");
  ASSERT_EQ(etag.front(), '"');
  EXPECT_EQ(http.request("PUT", "/v1/images/a/lines", body, {{"If-Match", "W/" + etag}}).status, 412) << "weak never matches";
  EXPECT_EQ(http.request("PUT", "/v1/images/a/lines", body, {{"If-Match", "\"x,y\", \"other\""}}).status, 412);
  auto listed = http.request("PUT", "/v1/images/a/lines", body, {{"If-Match", "\"other\", " + etag}});
  EXPECT_EQ(listed.status, 200) << listed.body;
  EXPECT_NE(listed.header("etag"), etag);
  etag = listed.header("etag");
  EXPECT_EQ(http.request("PUT", "/v1/images/a/lines", body, {{"If-Match", "*"}}).status, 200);
  EXPECT_EQ(http.request("PUT", "/v1/images/a/lines", body, {{"If-Match", etag}}).status, 412) << "stale since";

  // If-None-Match: weak comparison and lists.
  const std::string view = "/v1/images/a/viewport?zoom=0.5&w=64&h=64";
  const std::string view_etag = http.get(view).header("etag");
  EXPECT_EQ(http.get(view, {{"If-None-Match", "W/" + view_etag}}).status, 304);
  EXPECT_EQ(http.get(view, {{"If-None-Match", "\"other\", " + view_etag}}).status, 304);
  EXPECT_EQ(http.get(view, {{"If-None-Match", "\"other\""}}).status, 200);
}

TEST_F(Protocol, ARepeatedQueryParameterIs400OnEveryRoute) {
  HttpClient http(server_->port());
  for (const std::string target : {"/v1/images/a/viewport?zoom=0&zoom=1&w=64&h=64", "/v1/images/a/mesh?w=64&h=64&w=65",
                                   "/dzi/a_files/0/0_0.jpg?v=1&v=2", "/dzi/a.dzi?v=1&v=1", "/iiif/3/a/info.json?x=&x=",
                                   "/v1/images?a=1&a=2"}) {
    auto r = http.get(target);
    EXPECT_EQ(r.status, 400) << target;
    EXPECT_EQ(json::parse(r.body, nullptr, false)["error"]["code"], "invalid_query") << target << r.body;
  }
  auto upload = http.request("POST", "/v1/images?id=one&id=two", testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg"));
  EXPECT_EQ(upload.status, 400) << upload.body;
  EXPECT_EQ(http.get("/v1/images/one").status, 404);
  EXPECT_EQ(http.get("/v1/images/two").status, 404);
  // Tiles and descriptors take no parameters and ignore one given once (a viewer's cache buster).
  EXPECT_EQ(http.get("/dzi/a_files/0/0_0.jpg?v=1").status, 200);
}

TEST_F(Protocol, SignificanceAndLinesRefuseUnknownParametersLikeMesh) {
  HttpClient http(server_->port());
  EXPECT_EQ(http.get("/v1/images/a/mesh?w=64&h=64&bogus=1").status, 400);
  EXPECT_EQ(http.get("/v1/images/a/significance.png?bogus=1").status, 400);
  EXPECT_EQ(http.get("/v1/images/a/lines?bogus=1").status, 400);
  EXPECT_EQ(http.get("/v1/images/a/significance.png").status, 200);
  EXPECT_EQ(http.get("/v1/images/a/lines").status, 200);
}

}  // namespace
}  // namespace zoomwarp
