// The S3 client (tiles/s3_client.h) against a real S3 server, OpenStack Swift with s3api on
// loopback (tests/support/swift_s3.h: one per process, so suite S3ClientSwift runs as one
// process): byte-exact round trips from memory and streamed from a file, ranges at the edges,
// missing keys and buckets, listings with prefix, delimiter and continuation, keys that need
// encoding, refused credentials, a paused server, many threads at once.
//
// Faults Swift will not produce on demand (503 SlowDown, 500, 429, a server that ignores Range, a
// connection that hangs) come from StubS3 below, a scripted HTTP/1.1 responder on a loopback port
// it picks (suite S3ClientFaults). Tests bound how long a failure may take (deadline + slack),
// never how fast a success is.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/swift_s3.h"
#include "tiles/s3_client.h"
#include "tiles/source_digest.h"

namespace zoomwarp {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using test::SwiftS3;
using tiles::S3Client;
using tiles::S3ClientOptions;
using tiles::S3Config;
using tiles::S3Deadline;
using tiles::S3Error;
using tiles::S3ListPage;
using tiles::S3Operation;
using tiles::S3Stats;

S3Deadline in(Clock::duration d) { return Clock::now() + d; }

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::string random_bytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (auto& c : s) c = char(rng());
  return s;
}

// A temporary folder, removed with everything in it.
class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/s3_client_test-XXXXXX";
    if (::mkdtemp(tmpl) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  std::string write(const std::string& name, const std::string& bytes) const {
    const std::string p = path_ + "/" + name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }

 private:
  std::string path_;
};

// The S3Error `f` throws; the test fails if it throws none.
template <class F>
S3Error s3_error_of(F&& f) {
  try {
    f();
  } catch (const S3Error& e) {
    return e;
  }
  ADD_FAILURE() << "no S3Error thrown";
  return S3Error(S3Error::Details{});
}

std::uint64_t requests(const S3Stats& s, S3Operation op) { return s.requests[std::size_t(op)]; }
std::uint64_t failures(const S3Stats& s, S3Operation op) { return s.failures[std::size_t(op)]; }

// Fast retries: the tests are about which failures are retried and how long they may take.
S3ClientOptions quick_retries(int attempts = 5) {
  S3ClientOptions o;
  o.max_attempts = attempts;
  o.base_backoff = 10ms;
  o.max_backoff = 100ms;
  return o;
}

// ---------------------------------------------------------------------------------------------
// Against Swift: one server per process, one bucket per suite.

class S3ClientSwift : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { bucket_ = SwiftS3::shared().new_bucket("s3client"); }
  static S3Config config(std::string secret = SwiftS3::kSecretKey) {
    return S3Config(SwiftS3::kAccessKey, std::move(secret), SwiftS3::kRegion, SwiftS3::shared().endpoint());
  }
  static inline std::string bucket_;
  S3Client client_{config()};
};

TEST_F(S3ClientSwift, RoundTripsAreByteExactFromMemoryAndFromAFile) {
  const std::string all_bytes = [] {
    std::string s;
    for (int i = 0; i < 256; ++i) s += char(i);
    return s;
  }();
  for (const std::string& body : {std::string(), std::string("x"), all_bytes, random_bytes(100'000, 1)}) {
    const std::string key = "roundtrip/mem-" + std::to_string(body.size());
    const std::string etag = client_.put(bucket_, key, body, "application/octet-stream", in(10s));
    EXPECT_EQ(etag.size(), 32u) << etag;  // a single-part upload's ETag is its MD5, quotes removed
    const auto got = client_.get(bucket_, key, in(10s));
    ASSERT_TRUE(got.has_value()) << key;
    EXPECT_EQ(got->size(), body.size());
    EXPECT_TRUE(*got == body) << key;
    const auto info = client_.head(bucket_, key, in(10s));
    ASSERT_TRUE(info.has_value());
    EXPECT_EQ(info->size, body.size());
    EXPECT_EQ(info->etag, etag);
    EXPECT_EQ(info->content_type, "application/octet-stream");
  }

  // A few MB streamed from a file (more than libcurl's 1 MiB Expect: 100-continue threshold), the
  // hash computed by the client, then handed in by the caller.
  TempDir dir;
  const std::string big = random_bytes(3 * 1024 * 1024 + 123, 2);
  const std::string path = dir.write("level_0.tif", big);
  const std::string etag = client_.put_file(bucket_, "roundtrip/file", path, "image/tiff", in(30s));
  EXPECT_EQ(client_.get(bucket_, "roundtrip/file", in(30s)).value_or("") == big, true);
  EXPECT_EQ(client_.head(bucket_, "roundtrip/file", in(10s))->etag, etag);
  EXPECT_EQ(client_.put_file(bucket_, "roundtrip/file2", path, "image/tiff", in(30s), tiles::file_sha256_hex(path)),
            etag);
  EXPECT_EQ(client_.get(bucket_, "roundtrip/file2", in(30s)).value_or("") == big, true);
  const std::string empty = dir.write("empty", "");
  client_.put_file(bucket_, "roundtrip/empty-file", empty, "", in(10s));
  EXPECT_EQ(client_.get(bucket_, "roundtrip/empty-file", in(10s)), std::string());

  // The store checks the body against x-amz-content-sha256: a wrong digest is refused, not retried.
  const auto before = client_.stats();
  const S3Error e = s3_error_of([&] {
    client_.put_file(bucket_, "roundtrip/wrong-hash", path, "", in(30s), std::string(64, '0'));
  });
  EXPECT_EQ(e.status(), 400) << e.what();
  // AWS's code for it; Swift's s3api answers BadDigest.
  EXPECT_TRUE(e.code() == "XAmzContentSHA256Mismatch" || e.code() == "BadDigest") << e.what();
  EXPECT_FALSE(e.unavailable());
  EXPECT_EQ(requests(client_.stats(), S3Operation::kPutFile) - requests(before, S3Operation::kPutFile), 1u);
  EXPECT_FALSE(client_.head(bucket_, "roundtrip/wrong-hash", in(10s)).has_value());
  EXPECT_THROW(client_.put_file(bucket_, "roundtrip/x", dir.write("x", "") + ".missing", "", in(10s)),
               std::system_error);
}

// Issue 42: a file over the multipart threshold (lowered here from 1 GiB) goes up in parts — 5
// MiB, S3's smallest — and comes back byte for byte, with its content type; a part's failure
// (the store refusing the upload) aborts the upload and leaves no object.
TEST_F(S3ClientSwift, AFileOverTheThresholdGoesUpInPartsWhole) {
  S3ClientOptions o;
  o.multipart_threshold = 6u << 20;
  o.multipart_part_bytes = 5u << 20;
  S3Client client(config(), o);
  TempDir dir;
  const std::string big = random_bytes(12 * 1024 * 1024 + 4321, 7);  // 3 parts: 5, 5 and 2 MiB
  const std::string path = dir.write("level_0.tif", big);
  const auto before = client.stats();
  const std::string etag = client.put_file(bucket_, "multipart/level_0.tif", path, "image/tiff", in(60s));
  EXPECT_EQ(requests(client.stats(), S3Operation::kPutFile) - requests(before, S3Operation::kPutFile), 5u)
      << "create, three parts, complete";
  EXPECT_EQ(client.get(bucket_, "multipart/level_0.tif", in(30s)).value_or("") == big, true);
  const auto info = client.head(bucket_, "multipart/level_0.tif", in(10s));
  ASSERT_TRUE(info.has_value());
  EXPECT_EQ(info->size, big.size());
  EXPECT_EQ(info->content_type, "image/tiff");
  EXPECT_NE(etag.find("-3"), std::string::npos) << "a multipart ETag counts its parts: " << etag;
  // Under the threshold: one PUT, as before.
  const std::string small = dir.write("small", random_bytes(1 << 20, 8));
  EXPECT_EQ(client.put_file(bucket_, "multipart/small", small, "", in(30s)).size(), 32u);
  // Refused (a bucket that does not exist): thrown, nothing left behind.
  EXPECT_THROW(client.put_file("no-such-bucket-here", "multipart/x", path, "", in(30s)), S3Error);
}

TEST_F(S3ClientSwift, RangesAreExactlyTheBytesAskedFor) {
  constexpr std::size_t n = 100'000;
  const std::string body = random_bytes(n, 3);
  client_.put(bucket_, "ranges/obj", body, "", in(10s));
  struct Range {
    std::uint64_t offset, length;
  };
  for (const Range r : {Range{0, 1}, Range{n - 1, 1}, Range{0, n}, Range{12345, 54321}, Range{n - 10, 10},
                        Range{65535, 2}}) {
    const auto got = client_.get_range(bucket_, "ranges/obj", r.offset, r.length, in(10s));
    ASSERT_TRUE(got.has_value());
    EXPECT_TRUE(*got == body.substr(r.offset, r.length)) << r.offset << "+" << r.length;
  }
  // Past the end: partly (the store sends what there is: fewer bytes than asked), wholly (416).
  const S3Error short_range = s3_error_of([&] { client_.get_range(bucket_, "ranges/obj", n - 5, 10, in(10s)); });
  EXPECT_EQ(short_range.status(), 206) << short_range.what();
  EXPECT_EQ(short_range.code(), "ShortRange");
  const S3Error outside = s3_error_of([&] { client_.get_range(bucket_, "ranges/obj", n, 1, in(10s)); });
  EXPECT_EQ(outside.status(), 416) << outside.what();
  EXPECT_EQ(outside.code(), "InvalidRange");
  EXPECT_FALSE(outside.unavailable());

  EXPECT_FALSE(client_.get_range(bucket_, "ranges/missing", 0, 10, in(10s)).has_value());
  EXPECT_THROW(client_.get_range(bucket_, "ranges/obj", 0, 0, in(10s)), std::invalid_argument);
}

TEST_F(S3ClientSwift, MissingKeysAreNotFoundMissingBucketsAreErrors) {
  EXPECT_FALSE(client_.get(bucket_, "missing/key", in(10s)).has_value());
  EXPECT_FALSE(client_.head(bucket_, "missing/key", in(10s)).has_value());
  EXPECT_NO_THROW(client_.remove(bucket_, "missing/key", in(10s)));

  client_.put(bucket_, "missing/then-removed", "bytes", "text/plain", in(10s));
  ASSERT_TRUE(client_.head(bucket_, "missing/then-removed", in(10s)).has_value());
  client_.remove(bucket_, "missing/then-removed", in(10s));
  EXPECT_FALSE(client_.get(bucket_, "missing/then-removed", in(10s)).has_value());
  client_.remove(bucket_, "missing/then-removed", in(10s));  // again: still fine

  const std::string no_bucket = "no-such-bucket-" + std::to_string(::getpid());
  const S3Error e = s3_error_of([&] { client_.get(no_bucket, "k", in(10s)); });
  EXPECT_EQ(e.status(), 404);
  EXPECT_EQ(e.code(), "NoSuchBucket");
  EXPECT_EQ(e.details().bucket, no_bucket);
  EXPECT_EQ(e.details().key, "k");
  EXPECT_EQ(e.details().operation, S3Operation::kGet);
  EXPECT_NE(std::string(e.what()).find("s3://" + no_bucket + "/k"), std::string::npos) << e.what();
  EXPECT_EQ(s3_error_of([&] { client_.remove(no_bucket, "k", in(10s)); }).code(), "NoSuchBucket");
  EXPECT_EQ(s3_error_of([&] { client_.list(no_bucket, "", "", "", in(10s)); }).code(), "NoSuchBucket");
  EXPECT_FALSE(client_.head(no_bucket, "k", in(10s)).has_value());  // HEAD cannot tell

  // Buckets: created once, then "already ours".
  const std::string fresh = "s3client-fresh-" + std::to_string(::getpid());
  EXPECT_TRUE(client_.create_bucket(fresh, in(10s)));
  EXPECT_FALSE(client_.create_bucket(fresh, in(10s)));
  client_.put(fresh, "k", "v", "", in(10s));
  EXPECT_EQ(client_.get(fresh, "k", in(10s)), "v");
  EXPECT_THROW(client_.create_bucket("Not_A_Bucket", in(10s)), std::invalid_argument);
}

TEST_F(S3ClientSwift, ListsWithPrefixDelimiterAndContinuation) {
  std::set<std::string> files = {"list/a", "list/b", "list/c/1", "list/c/2", "list/d/x"};
  for (int i = 0; i < 7; ++i) files.insert("list/page-" + std::to_string(i));
  std::map<std::string, std::string> etags;
  for (const auto& k : files) etags[k] = client_.put(bucket_, k, "body of " + k, "", in(10s));
  client_.put(bucket_, "listed-not", "other prefix", "", in(10s));

  // Three keys a page: continuation tokens must carry the listing through.
  std::vector<std::string> keys, prefixes;
  std::string token;
  int pages = 0;
  for (;;) {
    const S3ListPage page = client_.list(bucket_, "list/", "/", token, in(10s), 3);
    ++pages;
    EXPECT_LE(page.objects.size() + page.common_prefixes.size(), 3u);
    for (const auto& o : page.objects) {
      keys.push_back(o.key);
      EXPECT_EQ(o.size, ("body of " + o.key).size());
      EXPECT_EQ(o.etag, etags[o.key]);
    }
    prefixes.insert(prefixes.end(), page.common_prefixes.begin(), page.common_prefixes.end());
    if (!page.truncated) break;
    ASSERT_FALSE(page.next_continuation.empty());
    token = page.next_continuation;
    ASSERT_LT(pages, 20);
  }
  EXPECT_GE(pages, 4);
  EXPECT_EQ(keys, (std::vector<std::string>{"list/a", "list/b", "list/page-0", "list/page-1", "list/page-2",
                                            "list/page-3", "list/page-4", "list/page-5", "list/page-6"}));
  EXPECT_EQ(prefixes, (std::vector<std::string>{"list/c/", "list/d/"}));

  // Without a delimiter: every key under the prefix, in order.
  const S3ListPage all = client_.list(bucket_, "list/", "", "", in(10s));
  EXPECT_FALSE(all.truncated);
  std::vector<std::string> all_keys;
  for (const auto& o : all.objects) all_keys.push_back(o.key);
  EXPECT_EQ(all_keys, std::vector<std::string>(files.begin(), files.end()));
  EXPECT_TRUE(all.common_prefixes.empty());
  EXPECT_TRUE(client_.list(bucket_, "list/none/", "/", "", in(10s)).objects.empty());
  EXPECT_THROW(client_.list(bucket_, "", "", "", in(10s), 0), std::invalid_argument);
}

TEST_F(S3ClientSwift, KeysThatNeedEncoding) {
  const std::vector<std::string> keys = {
      "enc/a b",    "enc/a+b",           "enc/\xc3\xbc/\xc3\xb1 \xe6\xbc\xa2\xe5\xad\x97",  // ü/ñ 漢字
      "enc/x%20y",  "enc/tilde~_.-",     "enc/semi;colon=eq&amp",
      "enc/q?mark", "enc/hash#frag",     "enc/star*paren()'!",
      "enc/a//b",   "enc/back\\slash",   "enc/<xml>&\"quote\"",
      "enc/dots/../up", "enc/./here",  // names, not paths: nothing may resolve them
  };
  for (const auto& k : keys) {
    SCOPED_TRACE(k);
    client_.put(bucket_, k, "value of " + k, "text/plain", in(10s));
    EXPECT_EQ(client_.get(bucket_, k, in(10s)), "value of " + k);
    EXPECT_EQ(client_.get_range(bucket_, k, 0, 5, in(10s)), "value");
    ASSERT_TRUE(client_.head(bucket_, k, in(10s)).has_value());
  }
  std::vector<std::string> listed;
  std::string token;
  do {
    const S3ListPage page = client_.list(bucket_, "enc/", "", token, in(10s), 5);
    for (const auto& o : page.objects) listed.push_back(o.key);
    token = page.next_continuation;
  } while (!token.empty());
  std::vector<std::string> sorted = keys;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(listed, sorted);
  // A prefix and delimiter that need encoding themselves.
  const S3ListPage under = client_.list(bucket_, "enc/a", "+", "", in(10s));
  ASSERT_EQ(under.common_prefixes, std::vector<std::string>{"enc/a+"});
  for (const auto& k : keys) client_.remove(bucket_, k, in(10s));
  EXPECT_TRUE(client_.list(bucket_, "enc/", "", "", in(10s)).objects.empty());
}

TEST_F(S3ClientSwift, RefusedCredentialsAre403WithAClearMessageAndNotRetried) {
  S3Client wrong(config("not-the-secret"));
  const S3Error e = s3_error_of([&] { wrong.get(bucket_, "k", in(10s)); });
  EXPECT_EQ(e.status(), 403) << e.what();
  EXPECT_TRUE(e.credentials_refused()) << e.what();
  EXPECT_FALSE(e.unavailable());
  EXPECT_EQ(e.details().attempts, 1);
  const std::string what = e.what();
  EXPECT_NE(what.find("the store refused the credentials"), std::string::npos) << what;
  EXPECT_NE(what.find("AWS_SECRET_ACCESS_KEY"), std::string::npos) << what;
  EXPECT_EQ(what.find("not-the-secret"), std::string::npos) << what;
  EXPECT_EQ(requests(wrong.stats(), S3Operation::kGet), 1u);
  EXPECT_EQ(failures(wrong.stats(), S3Operation::kGet), 1u);
  EXPECT_EQ(wrong.stats().retries, 0u);
  // A HEAD answer has no body: still 403, and the message says what it may be.
  const S3Error h = s3_error_of([&] { wrong.head(bucket_, "k", in(10s)); });
  EXPECT_EQ(h.status(), 403);
  EXPECT_NE(std::string(h.what()).find("credentials"), std::string::npos) << h.what();
  // The wrong region: the store names it, and so does the message.
  S3Client elsewhere(S3Config(SwiftS3::kAccessKey, SwiftS3::kSecretKey, "eu-west-1", SwiftS3::shared().endpoint()));
  const S3Error r = s3_error_of([&] { elsewhere.get(bucket_, "k", in(10s)); });
  EXPECT_EQ(r.status(), 400) << r.what();
  EXPECT_NE(std::string(r.what()).find("AWS_REGION"), std::string::npos) << r.what();
}

TEST_F(S3ClientSwift, APausedServerGivesATimeoutByTheDeadlineAndServiceResumes) {
  client_.put(bucket_, "paused/k", "v", "", in(10s));
  ASSERT_EQ(client_.get(bucket_, "paused/k", in(10s)), "v");  // a warm connection, too

  SwiftS3::shared().pause();
  struct Resume {
    ~Resume() { SwiftS3::shared().resume(); }
  } resume;
  for (const auto budget : {800ms, 1500ms}) {
    const auto t0 = Clock::now();
    const S3Error e = s3_error_of([&] { client_.get(bucket_, "paused/k", t0 + budget); });
    const double took = seconds_since(t0);
    EXPECT_TRUE(e.unavailable()) << e.what();
    EXPECT_TRUE(e.timed_out()) << e.what();
    EXPECT_EQ(e.status(), 0);
    EXPECT_GE(took, std::chrono::duration<double>(budget).count() - 0.05);
    EXPECT_LT(took, std::chrono::duration<double>(budget).count() + 0.3) << e.what();
  }
  SwiftS3::shared().resume();
  // Back by itself: the next request (with the time a request normally has) gets its answer.
  EXPECT_EQ(client_.get(bucket_, "paused/k", in(10s)), "v");
}

TEST_F(S3ClientSwift, ManyThreadsShareOneClient) {
  constexpr int kThreads = 8, kRounds = 6;
  const S3Stats before = client_.stats();
  std::atomic<int> wrong{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < kRounds; ++i) {
        const std::string key = "threads/" + std::to_string(t) + "/" + std::to_string(i);
        const std::string body = random_bytes(1000 + 997 * std::size_t(t * kRounds + i), unsigned(t * 100 + i));
        try {
          client_.put(bucket_, key, body, "", in(30s));
          if (client_.get(bucket_, key, in(30s)) != body) ++wrong;
          if (client_.get_range(bucket_, key, 10, 100, in(30s)) != body.substr(10, 100)) ++wrong;
          if (client_.head(bucket_, key, in(30s)).value_or(tiles::S3ObjectInfo{}).size != body.size()) ++wrong;
        } catch (const std::exception& e) {
          ADD_FAILURE() << e.what();
          ++wrong;
        }
      }
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(wrong, 0);
  const S3Stats after = client_.stats();
  constexpr std::uint64_t kOps = kThreads * kRounds;
  EXPECT_GE(requests(after, S3Operation::kPut) - requests(before, S3Operation::kPut), kOps);
  EXPECT_GE(requests(after, S3Operation::kGet) - requests(before, S3Operation::kGet), kOps);
  EXPECT_GE(requests(after, S3Operation::kGetRange) - requests(before, S3Operation::kGetRange), kOps);
  EXPECT_GE(requests(after, S3Operation::kHead) - requests(before, S3Operation::kHead), kOps);
  EXPECT_EQ(failures(after, S3Operation::kGet), failures(before, S3Operation::kGet));
  EXPECT_GT(after.bytes_sent - before.bytes_sent, 0u);
  EXPECT_GT(after.bytes_received - before.bytes_received, 0u);
  const S3ListPage listed = client_.list(bucket_, "threads/", "", "", in(10s));
  EXPECT_EQ(listed.objects.size(), std::size_t(kOps));
}

// ---------------------------------------------------------------------------------------------
// Faults, from a scripted stand-in.

// A scripted HTTP/1.1 server on 127.0.0.1 and an ephemeral port: answers each request with the
// next reply of its script (the last one again once the script is used up) and records what it
// received, keeping connections alive as S3 does. With `hang`, it accepts connections and never
// reads or answers. One thread; stops (closing everything) when destroyed.
class StubS3 {
 public:
  struct Reply {
    Reply(int s, std::string b = {}, std::string h = {}) : status(s), body(std::move(b)), headers(std::move(h)) {}
    int status;
    std::string body;
    std::string headers;  // extra header lines, each ending in "\r\n"
  };
  struct Received {
    std::string method, target, head, body;
  };

  explicit StubS3(std::vector<Reply> script, bool hang = false) : script_(std::move(script)), hang_(hang) {
    listener_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (listener_ < 0 || ::bind(listener_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(listener_, 16) != 0 || ::getsockname(listener_, reinterpret_cast<sockaddr*>(&a), &len) != 0)
      throw std::runtime_error("stub: cannot listen");
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this] { serve(); });
  }
  ~StubS3() {
    stop_ = true;
    thread_.join();
    for (int fd : held_) ::close(fd);
    ::close(listener_);
  }

  std::string endpoint() const { return "http://127.0.0.1:" + std::to_string(port_); }
  std::vector<Received> received() const {
    std::lock_guard lock(mu_);
    return received_;
  }
  int connections() const { return connections_; }

  static std::string error_xml(const std::string& code) {
    return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<Error><Code>" + code + "</Code><Message>stub says " + code +
           "</Message><RequestId>stub-1</RequestId></Error>";
  }

 private:
  // Waits up to 20 ms for `fd` to be readable; false when stopping.
  bool wait_readable(int fd) {
    while (!stop_) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 20) > 0) return true;
    }
    return false;
  }

  void serve() {
    while (wait_readable(listener_)) {
      const int fd = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd < 0) continue;
      ++connections_;
      if (hang_) {
        held_.push_back(fd);
        continue;
      }
      serve_connection(fd);
      ::close(fd);
    }
  }

  // Requests on one connection until the client closes it (or the test ends).
  void serve_connection(int fd) {
    std::string buffer;
    auto fill = [&]() {
      char chunk[65536];
      if (!wait_readable(fd)) return false;
      const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
      if (n <= 0) return false;
      buffer.append(chunk, std::size_t(n));
      return true;
    };
    for (;;) {
      std::size_t end;
      while ((end = buffer.find("\r\n\r\n")) == std::string::npos)
        if (!fill()) return;
      Received r;
      r.head = buffer.substr(0, end + 2);
      buffer.erase(0, end + 4);
      const std::size_t sp1 = r.head.find(' '), sp2 = r.head.find(' ', sp1 + 1);
      r.method = r.head.substr(0, sp1);
      r.target = r.head.substr(sp1 + 1, sp2 - sp1 - 1);
      std::string lower = r.head;
      std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
      std::size_t length = 0;
      if (auto p = lower.find("\r\ncontent-length:"); p != std::string::npos)
        length = std::stoul(lower.substr(p + 17));
      if (lower.find("\r\nexpect: 100-continue") != std::string::npos && buffer.size() < length)
        send_all(fd, "HTTP/1.1 100 Continue\r\n\r\n");
      while (buffer.size() < length)
        if (!fill()) return;
      r.body = buffer.substr(0, length);
      buffer.erase(0, length);
      const bool head = r.method == "HEAD";
      std::size_t index;
      {
        std::lock_guard lock(mu_);
        index = received_.size();
        received_.push_back(std::move(r));
      }
      const Reply& reply = script_[std::min(index, script_.size() - 1)];
      std::string answer = "HTTP/1.1 " + std::to_string(reply.status) + " Stub\r\nContent-Length: " +
                           std::to_string(reply.body.size()) + "\r\n" + reply.headers + "\r\n";
      if (!head) answer += reply.body;
      if (!send_all(fd, answer)) return;
    }
  }

  static bool send_all(int fd, std::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n <= 0) return false;
      bytes.remove_prefix(std::size_t(n));
    }
    return true;
  }

  std::vector<Reply> script_;
  bool hang_;
  int listener_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<int> connections_{0};
  std::vector<int> held_;  // hang: accepted and left alone (only the stub's thread touches it until join)
  mutable std::mutex mu_;
  std::vector<Received> received_;
  std::thread thread_;
};

S3Config stub_config(const StubS3& stub) { return S3Config("test:tester", "testing", "us-east-1", stub.endpoint()); }

// A port nothing listens on: bound, then closed.
int closed_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

TEST(S3ClientFaults, SlowDownAndOtherTransientAnswersAreRetriedAndCounted) {
  StubS3 stub({{503, StubS3::error_xml("SlowDown")},
               {429, StubS3::error_xml("TooManyRequests")},
               {500, StubS3::error_xml("InternalError")},
               {502, ""},
               {200, "finally"}});
  S3Client client(stub_config(stub), quick_retries(5));
  EXPECT_EQ(client.get("bucket", "key", in(10s)), "finally");
  EXPECT_EQ(stub.received().size(), 5u);
  const S3Stats s = client.stats();
  EXPECT_EQ(requests(s, S3Operation::kGet), 5u);
  EXPECT_EQ(s.retries, 4u);
  EXPECT_EQ(failures(s, S3Operation::kGet), 0u);
  // Every attempt is signed, with the payload hash we send and the access key with its colon.
  for (const auto& r : stub.received()) {
    EXPECT_EQ(r.target, "/bucket/key");
    EXPECT_NE(r.head.find("x-amz-content-sha256: e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"),
              std::string::npos)
        << r.head;
    EXPECT_NE(r.head.find("Authorization: AWS4-HMAC-SHA256 Credential=test:tester/"), std::string::npos) << r.head;
  }
}

TEST(S3ClientFaults, ThrottlingUntilTheAttemptsRunOutIsUnavailable) {
  StubS3 stub({{503, StubS3::error_xml("SlowDown"), "x-amz-request-id: req-42\r\n"}});
  S3Client client(stub_config(stub), quick_retries(3));
  const S3Error e = s3_error_of([&] { client.get("bucket", "key", in(10s)); });
  EXPECT_EQ(e.status(), 503);
  EXPECT_EQ(e.code(), "SlowDown");
  EXPECT_EQ(e.details().message, "stub says SlowDown");
  EXPECT_TRUE(e.unavailable());
  EXPECT_FALSE(e.timed_out());
  EXPECT_EQ(e.details().attempts, 3);
  EXPECT_EQ(stub.received().size(), 3u);
  EXPECT_EQ(client.stats().retries, 2u);
  EXPECT_EQ(failures(client.stats(), S3Operation::kGet), 1u);
}

// The store's Retry-After is honoured (issue 42): the retry waits at least as long as it asks, even
// with a backoff of 100 ms at most; one that asks past the deadline fails at once, unavailable.
TEST(S3ClientFaults, RetryAfterIsHonouredAndOnePastTheDeadlineFailsAtOnce) {
  StubS3 stub({{503, StubS3::error_xml("SlowDown"), "Retry-After: 1\r\n"}, {200, "after a second"}});
  S3Client client(stub_config(stub), quick_retries(5));
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(client.get("bucket", "key", in(10s)), "after a second");
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 1s);
  EXPECT_EQ(stub.received().size(), 2u);

  StubS3 later({{503, StubS3::error_xml("SlowDown"), "Retry-After: 30\r\n"}, {200, "too late"}});
  S3Client impatient(stub_config(later), quick_retries(5));
  const auto t1 = std::chrono::steady_clock::now();
  const S3Error e = s3_error_of([&] { impatient.get("bucket", "key", in(3s)); });
  EXPECT_LT(std::chrono::steady_clock::now() - t1, 2s) << "not waited out";
  EXPECT_EQ(e.code(), "SlowDown");
  EXPECT_TRUE(e.unavailable());
  EXPECT_EQ(later.received().size(), 1u);
}

TEST(S3ClientFaults, ClientErrorsAreFinalAtOnce) {
  for (const auto& [status, code] : std::vector<std::pair<int, std::string>>{
           {400, "InvalidArgument"}, {403, "AccessDenied"}, {409, "Conflict"}, {501, "NotImplemented"}}) {
    StubS3 stub({{status, StubS3::error_xml(code)}, {200, "never"}});
    S3Client client(stub_config(stub), quick_retries(5));
    const S3Error e = s3_error_of([&] { client.get("bucket", "key", in(10s)); });
    EXPECT_EQ(e.status(), status);
    EXPECT_EQ(e.code(), code);
    EXPECT_FALSE(e.unavailable());
    EXPECT_EQ(stub.received().size(), 1u) << code;
    EXPECT_EQ(client.stats().retries, 0u);
  }
}

TEST(S3ClientFaults, AFileBodyIsSentWholeAgainOnARetry) {
  TempDir dir;
  for (const std::size_t size : {std::size_t(300'000), std::size_t(2'500'000)}) {  // below and above Expect: 100-continue
    StubS3 stub({{503, StubS3::error_xml("SlowDown")}, {500, StubS3::error_xml("InternalError")},
                 {200, "", "ETag: \"abc\"\r\n"}});
    const std::string body = random_bytes(size, unsigned(size));
    const std::string path = dir.write("f" + std::to_string(size), body);
    S3Client client(stub_config(stub), quick_retries(5));
    EXPECT_EQ(client.put_file("bucket", "dir/level 0.tif", path, "image/tiff", in(20s)), "abc");
    const auto got = stub.received();
    ASSERT_EQ(got.size(), 3u);
    const std::string sha = tiles::file_sha256_hex(path);
    for (const auto& r : got) {
      EXPECT_EQ(r.method, "PUT");
      EXPECT_EQ(r.target, "/bucket/dir/level%200.tif");
      EXPECT_TRUE(r.body == body) << "attempt body of " << r.body.size() << " bytes";
      EXPECT_NE(r.head.find("x-amz-content-sha256: " + sha), std::string::npos) << r.head;
      EXPECT_NE(r.head.find("Content-Type: image/tiff"), std::string::npos);
    }
    EXPECT_EQ(client.stats().bytes_sent, 3 * size);
  }
}

TEST(S3ClientFaults, AnUnreachableStoreIsUnavailableWithinTheDeadline) {
  S3Client client(S3Config("k", "s", "us-east-1", "http://127.0.0.1:" + std::to_string(closed_port())),
                  quick_retries(100));
  const auto t0 = Clock::now();
  const S3Error e = s3_error_of([&] { client.get("bucket", "key", t0 + 1500ms); });
  EXPECT_LT(seconds_since(t0), 1.5 + 0.2);
  EXPECT_TRUE(e.unavailable()) << e.what();
  EXPECT_FALSE(e.timed_out()) << e.what();  // refused: down, not slow
  EXPECT_EQ(e.status(), 0);
  EXPECT_GT(e.details().attempts, 1);
  EXPECT_NE(std::string(e.what()).find("127.0.0.1"), std::string::npos) << e.what();
  EXPECT_EQ(client.stats().retries, std::uint64_t(e.details().attempts - 1));
}

TEST(S3ClientFaults, AHungServerTimesOutAtTheDeadline) {
  StubS3 stub({}, /*hang=*/true);
  S3Client client(stub_config(stub), quick_retries(5));
  const auto t0 = Clock::now();
  const S3Error e = s3_error_of([&] { client.get("bucket", "key", t0 + 1s); });
  EXPECT_GE(seconds_since(t0), 0.95);
  EXPECT_LT(seconds_since(t0), 1.0 + 0.25);
  EXPECT_TRUE(e.unavailable());
  EXPECT_TRUE(e.timed_out());
  EXPECT_EQ(e.status(), 0);
  EXPECT_EQ(stub.connections(), 1);  // no time was left for a second attempt
}

TEST(S3ClientFaults, TheLowSpeedLimitGivesUpOnAStalledAttemptAndRetries) {
  StubS3 stub({}, /*hang=*/true);
  S3ClientOptions o = quick_retries(2);
  o.low_speed_time = 1s;
  S3Client client(stub_config(stub), o);
  const auto t0 = Clock::now();
  const S3Error e = s3_error_of([&] { client.get("bucket", "key", t0 + 30s); });
  EXPECT_LT(seconds_since(t0), 6.0);  // two stalled attempts of ~1-2 s, not the 30 s deadline
  EXPECT_TRUE(e.timed_out());
  EXPECT_EQ(e.details().attempts, 2);
  EXPECT_EQ(stub.connections(), 2);
}

TEST(S3ClientFaults, ARangeTheStoreIgnoresIsCutNotDownloaded) {
  StubS3 stub({{200, std::string(4'000'000, 'x')}});
  S3Client client(stub_config(stub), quick_retries(5));
  const S3Error e = s3_error_of([&] { client.get_range("bucket", "key", 10, 100, in(10s)); });
  EXPECT_EQ(e.code(), "RangeIgnored") << e.what();
  EXPECT_EQ(stub.received().size(), 1u);
  EXPECT_NE(stub.received()[0].head.find("Range: bytes=10-109"), std::string::npos);
  EXPECT_LT(client.stats().bytes_received, 1'000'000u);
  // A 206 with the wrong bytes is caught too.
  StubS3 lying({{206, std::string(100, 'y'), "Content-Range: bytes 0-99/1000\r\n"}});
  S3Client client2(stub_config(lying), quick_retries(5));
  EXPECT_EQ(s3_error_of([&] { client2.get_range("bucket", "key", 10, 100, in(10s)); }).code(), "ShortRange");
}

TEST(S3ClientFaults, ADeadlineAlreadyPastMakesNoRequest) {
  StubS3 stub({{200, "x"}});
  S3Client client(stub_config(stub));
  const S3Error e = s3_error_of([&] { client.get("bucket", "key", Clock::now() - 1ms); });
  EXPECT_TRUE(e.timed_out());
  EXPECT_TRUE(e.unavailable());
  EXPECT_EQ(e.details().attempts, 0);
  EXPECT_EQ(stub.connections(), 0);
  EXPECT_EQ(requests(client.stats(), S3Operation::kGet), 0u);
}

TEST(S3ClientFaults, ArgumentsAreCheckedBeforeAnyRequest) {
  StubS3 stub({{200, "x"}});
  S3Client client(stub_config(stub));
  EXPECT_THROW(client.get("Bad_Bucket", "key", in(10s)), std::invalid_argument);
  EXPECT_THROW(client.get("bucket", "", in(10s)), std::invalid_argument);  // would GET the bucket's listing
  EXPECT_THROW(client.put("bucket", std::string(1025, 'k'), "", "", in(10s)), std::invalid_argument);
  EXPECT_THROW(client.list("b", "", "", "", in(10s)), std::invalid_argument);
  EXPECT_THROW(client.put_file("bucket", "key", "/dev/null", "", in(10s), "not-a-digest"), std::invalid_argument);
  EXPECT_EQ(stub.connections(), 0);
}

TEST(S3ClientFaults, ConnectionsAreReused) {
  StubS3 stub({{200, "x"}});
  S3Client client(stub_config(stub));
  for (int i = 0; i < 5; ++i) EXPECT_EQ(client.get("bucket", "key" + std::to_string(i), in(10s)), "x");
  EXPECT_EQ(stub.received().size(), 5u);
  EXPECT_EQ(stub.connections(), 1);
}

TEST(S3ClientFaults, ListingQueriesAreCanonicalAndKeysDecoded) {
  const std::string listing =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<ListBucketResult xmlns=\"http://s3.amazonaws.com/doc/2006-03-01/\"><Name>bucket</Name>"
      "<Prefix>a%2Fb</Prefix><KeyCount>2</KeyCount><MaxKeys>2</MaxKeys><Delimiter>%2F</Delimiter>"
      "<IsTruncated>true</IsTruncated><NextContinuationToken>tok/+=</NextContinuationToken>"
      "<Contents><Key>a/b+c%2Bd</Key><LastModified>2024-01-01T00:00:00.000Z</LastModified>"
      "<ETag>&quot;0123&quot;</ETag><Size>17</Size><StorageClass>STANDARD</StorageClass></Contents>"
      "<CommonPrefixes><Prefix>a/b%C3%BC/</Prefix></CommonPrefixes>"
      "<EncodingType>url</EncodingType></ListBucketResult>";
  StubS3 stub({{200, listing}});
  S3Client client(stub_config(stub));
  const S3ListPage page = client.list("bucket", "a/b", "/", "tok/+=", in(10s), 2);
  EXPECT_EQ(stub.received().at(0).target,
            "/bucket?continuation-token=tok%2F%2B%3D&delimiter=%2F&encoding-type=url&list-type=2&max-keys=2&prefix=a%2Fb");
  ASSERT_EQ(page.objects.size(), 1u);
  EXPECT_EQ(page.objects[0].key, "a/b c+d");  // AWS writes a space as '+'
  EXPECT_EQ(page.objects[0].size, 17u);
  EXPECT_EQ(page.objects[0].etag, "0123");
  EXPECT_EQ(page.common_prefixes, std::vector<std::string>{"a/b\xc3\xbc/"});
  EXPECT_TRUE(page.truncated);
  EXPECT_EQ(page.next_continuation, "tok/+=");

  StubS3 broken({{200, "<ListBucketResult><Contents><Key>x</Key>"}});
  S3Client client2(stub_config(broken));
  EXPECT_EQ(s3_error_of([&] { client2.list("bucket", "", "", "", in(10s)); }).code(), "InvalidResponse");
}

TEST(S3ClientFaults, TheSessionTokenIsSent) {
  StubS3 stub({{200, "x"}});
  S3Client client(S3Config("k", "s", "us-east-1", stub.endpoint(), "the-token"));
  client.get("bucket", "key", in(10s));
  const std::string head = stub.received().at(0).head;
  EXPECT_NE(head.find("x-amz-security-token: the-token"), std::string::npos) << head;
  // ...and signed, like the payload hash.
  const auto signed_headers = head.substr(head.find("SignedHeaders="), 120);
  EXPECT_NE(signed_headers.find("x-amz-security-token"), std::string::npos) << signed_headers;
  EXPECT_NE(signed_headers.find("x-amz-content-sha256"), std::string::npos) << signed_headers;
}

}  // namespace
}  // namespace zoomwarp
