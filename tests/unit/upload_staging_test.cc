// An upload's admission and staging without a socket (server/upload_staging.h): what a client
// would notice — the 503 ingest_busy and 429 refusals with Retry-After and their metrics, the
// 415, 422 and 413 answers to a body's first bytes before anything is written — and what the
// ingest and the disk see: the staged file byte for byte, and no folder or slot left behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "api/rate_limits.h"
#include "server/metrics.h"
#include "server/upload_admission.h"
#include "server/upload_staging.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/header_sniff.h"
#include "tiles/store.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using server::UploadContext;
using Staging = server::UploadStaging;

// "Bearer curator" is the valid key "cur-1"; anything else is invalid.
class FakeKeys : public api::Authenticator {
 public:
  Result authenticate(std::string_view authorization) const override {
    if (authorization == "Bearer curator") return {Outcome::kValid, {"cur-1", api::Role::kCurator}};
    return {authorization.empty() ? Outcome::kNoCredentials : Outcome::kInvalid, {}};
  }
  bool has_keys() const override { return true; }
};

api::Request upload_from(const std::string& address, const std::string& authorization = "") {
  api::Request req;
  req.method = "POST";
  req.path = "/v1/images/a";
  req.client_address = address;
  req.authorization = authorization;
  return req;
}

std::string header(const api::Response& r, const std::string& name) {
  for (const auto& [n, v] : r.headers)
    if (n == name) return v;
  return "";
}

json error_of(const api::Response& r) { return json::parse(*r.body)["error"]; }

// One slot, no byte cap, no rate limits; sources up to 4000 px a side and 5 MP.
class UploadStaging : public ::testing::Test {
 protected:
  testing::TempDir dir;
  tiles::Store store{dir.path() + "/store"};
  server::UploadAdmission slots{1, 0};
  api::RateLimits no_limits{api::RateLimitConfig{}};
  server::Metrics metrics;
  tiles::SourceLimits limits{.max_pixels = 5'000'000, .max_dimension = 4000};
  UploadContext context = context_with(slots, no_limits);

  // This store, metrics and source limits; uploads up to 1 MiB.
  UploadContext context_with(server::UploadAdmission& s, api::RateLimits& r, const api::Authenticator* keys = nullptr) {
    return {store, s, r, metrics, keys, limits, 1u << 20};
  }

  // The staging folders the store holds (the folder store keeps them under staging/).
  std::vector<fs::path> staged() const {
    std::vector<fs::path> found;
    for (const auto& e : fs::directory_iterator(dir.path() + "/store/staging")) found.push_back(e.path());
    return found;
  }

  // Hands `bytes` over as the session does, in pieces of at most `piece` bytes, the last one with
  // whole_body; then finish(). The first refusal, and in `taken` how many bytes were handed over.
  static std::optional<api::Response> feed(Staging& s, const std::string& bytes, std::size_t piece,
                                           std::size_t* taken = nullptr) {
    std::size_t at = 0;
    std::optional<api::Response> refusal;
    do {
      const auto space = s.space();
      const std::size_t n = std::min({piece, space.size(), bytes.size() - at});
      std::copy_n(bytes.data() + at, n, space.data());
      at += n;
      refusal = s.add(n, at == bytes.size());
    } while (!refusal && at < bytes.size());
    if (taken) *taken = at;
    return refusal ? refusal : s.finish();
  }

  static std::string png(int w, int h) {
    testing::TempDir tmp;
    testing::write_image(tmp.path() + "/image.png", testing::test_pattern(w, h, 3), 8);
    return testing::read_file(tmp.path() + "/image.png");
  }
};

const std::string kJpeg = "boats_lake_sunset.jpg";  // 2560x1600, ~630 KB: many pieces

TEST_F(UploadStaging, JpegAndPngAreStagedByteForByte) {
  const std::string jpeg = testing::read_file(testing::samples_dir() + "/" + kJpeg);
  ASSERT_GT(jpeg.size(), 4 * tiles::kHeaderSniffBytes);
  for (const std::string& bytes : {jpeg, png(300, 200)}) {
    for (std::size_t piece : {std::size_t(1000), std::size_t(1) << 20}) {  // the head gathered over many reads, or one
      Staging s(context);
      ASSERT_FALSE(s.admit(upload_from("10.0.0.1"), bytes.size()));
      const auto refusal = feed(s, bytes, piece);
      ASSERT_FALSE(refusal) << *refusal->body;
      ASSERT_FALSE(s.file().empty());
      EXPECT_EQ(fs::path(s.file()).parent_path(), staged().at(0)) << "in a staging folder of the store";
      EXPECT_TRUE(testing::read_file(s.file()) == bytes)
          << "size " << fs::file_size(s.file()) << " of " << bytes.size();
    }
  }
}

TEST_F(UploadStaging, FullSlotsAnswer503IngestBusyAndStageNothing) {
  Staging first(context);
  ASSERT_FALSE(first.admit(upload_from("10.0.0.1"), 1000));
  ASSERT_FALSE(feed(first, png(64, 64), 1 << 20));
  ASSERT_EQ(staged().size(), 1u);

  Staging second(context);
  const auto refusal = second.admit(upload_from("10.0.0.2"), 1000);
  ASSERT_TRUE(refusal);
  EXPECT_EQ(refusal->status, 503);
  EXPECT_EQ(error_of(*refusal)["code"], "ingest_busy");
  EXPECT_EQ(header(*refusal, "Retry-After"), "1");
  EXPECT_EQ(refusal->route, "overloaded");
  EXPECT_EQ(staged().size(), 1u) << "only the first upload's folder";
  const std::string counted = metrics.render();
  EXPECT_NE(counted.find("zoomwarp_uploads_total{key=\"\"} 1\n"), std::string::npos)
      << "the refused upload never reached the rate limits: " << counted;
}

TEST_F(UploadStaging, ChunkedUploadReservesTheUploadLimit) {
  server::UploadAdmission two_slots{2, 1u << 20};  // bytes capped at the upload limit
  const UploadContext capped = context_with(two_slots, no_limits);
  Staging chunked(capped);
  ASSERT_FALSE(chunked.admit(upload_from("10.0.0.1"), std::nullopt));
  const auto refusal = Staging(capped).admit(upload_from("10.0.0.2"), 10);
  ASSERT_TRUE(refusal) << "an upload without Content-Length takes --max-upload of the staging bytes";
  EXPECT_EQ(error_of(*refusal)["code"], "ingest_busy");
}

TEST_F(UploadStaging, RateLimitedAddressGets429WithRetryAfter) {
  api::RateLimits one_a_minute({.uploads_per_minute = 1});
  const UploadContext limited = context_with(slots, one_a_minute);
  ASSERT_FALSE(Staging(limited).admit(upload_from("10.0.0.1"), 1000));

  Staging again(limited);
  const auto refusal = again.admit(upload_from("10.0.0.1"), 1000);
  ASSERT_TRUE(refusal);
  EXPECT_EQ(refusal->status, 429);
  EXPECT_EQ(error_of(*refusal)["code"], "rate_limited");
  EXPECT_EQ(error_of(*refusal)["message"], "over the uploads per minute allowed to this address; retry after 60 s");
  EXPECT_EQ(header(*refusal, "Retry-After"), "60");
  EXPECT_EQ(refusal->route, "rate_limited");
  EXPECT_FALSE(Staging(limited).admit(upload_from("10.0.0.2"), 1000)) << "the refused upload gave its slot back";
  const std::string counted = metrics.render();
  EXPECT_NE(counted.find("zoomwarp_uploads_total{key=\"\"} 2\n"), std::string::npos) << counted;
  EXPECT_NE(counted.find("zoomwarp_rate_limited_total{key=\"\",limit=\"uploads_per_minute\"} 1\n"), std::string::npos)
      << counted;
}

TEST_F(UploadStaging, ValidKeyIsLimitedAsTheKeyWhereverItComesFrom) {
  FakeKeys keys;
  api::RateLimits one_a_minute({.uploads_per_minute = 1});
  const UploadContext limited = context_with(slots, one_a_minute, &keys);
  ASSERT_FALSE(Staging(limited).admit(upload_from("10.0.0.1"), 1000));
  ASSERT_FALSE(Staging(limited).admit(upload_from("10.0.0.1", "Bearer curator"), 1000)) << "the key's own budget";
  const auto refusal = Staging(limited).admit(upload_from("10.0.0.9", "Bearer curator"), 1000);
  ASSERT_TRUE(refusal) << "the key's budget is spent, from any address";
  EXPECT_EQ(error_of(*refusal)["message"], "over the uploads per minute allowed to this key; retry after 60 s");
  const auto invalid = Staging(limited).admit(upload_from("10.0.0.1", "Bearer wrong"), 1000);
  ASSERT_TRUE(invalid) << "an invalid key counts against its address, whose budget is spent";
  EXPECT_EQ(error_of(*invalid)["message"], "over the uploads per minute allowed to this address; retry after 60 s");
  const std::string counted = metrics.render();
  EXPECT_NE(counted.find("zoomwarp_uploads_total{key=\"cur-1\"} 1\n"), std::string::npos) << counted;
  EXPECT_NE(counted.find("zoomwarp_rate_limited_total{key=\"cur-1\",limit=\"uploads_per_minute\"} 1\n"),
            std::string::npos)
      << counted;
}

TEST_F(UploadStaging, GarbageIs415AfterItsFirstBytesAndStagesNothing) {
  Staging s(context);
  ASSERT_FALSE(s.admit(upload_from("10.0.0.1"), 200000));
  std::size_t taken = 0;
  const auto refusal = feed(s, std::string(200000, 'x'), 1000, &taken);
  ASSERT_TRUE(refusal);
  EXPECT_EQ(refusal->status, 415);
  EXPECT_EQ(error_of(*refusal)["code"], "unsupported_format");
  EXPECT_EQ(taken, tiles::kHeaderSniffBytes) << "refused once the sniffed bytes were in, not read on";
  EXPECT_TRUE(s.file().empty());
  EXPECT_TRUE(staged().empty());
}

TEST_F(UploadStaging, UnreadableHeadersAre422) {
  const std::string whole = png(64, 64);
  {  // the one slot is given back at the end of the block
    Staging cut(context);
    ASSERT_FALSE(cut.admit(upload_from("10.0.0.1"), 20));
    const auto ends_inside = feed(cut, whole.substr(0, 20), 1 << 20);  // the IHDR chunk cut short
    ASSERT_TRUE(ends_inside);
    EXPECT_EQ(ends_inside->status, 422);
    EXPECT_EQ(error_of(*ends_inside)["message"], "the image ends inside its header");
  }

  std::string lying = whole;  // an IHDR whose CRC does not match
  lying[16] = char(0x7F);
  Staging corrupt(context);
  ASSERT_FALSE(corrupt.admit(upload_from("10.0.0.1"), lying.size()));
  const auto unreadable = feed(corrupt, lying, 1 << 20);
  ASSERT_TRUE(unreadable);
  EXPECT_EQ(unreadable->status, 422);
  EXPECT_EQ(error_of(*unreadable)["code"], "corrupt_image");
  EXPECT_EQ(error_of(*unreadable)["message"], "the image header is unreadable: the PNG header's checksum is wrong");
  EXPECT_TRUE(staged().empty());
}

TEST_F(UploadStaging, OverLimitSizeIs413BeforeAnythingIsWritten) {
  Staging s(context);
  const std::string wide = png(4001, 2);
  ASSERT_FALSE(s.admit(upload_from("10.0.0.1"), wide.size()));
  const auto refusal = feed(s, wide, 1 << 20);
  ASSERT_TRUE(refusal);
  EXPECT_EQ(refusal->status, 413);
  EXPECT_EQ(error_of(*refusal)["code"], "image_too_large");
  EXPECT_EQ(error_of(*refusal)["message"],
            "the image is 4001x2 pixels; the limits are 5000000 pixels and 4000 per side");
  EXPECT_TRUE(staged().empty());
}

TEST_F(UploadStaging, EmptyBodyStagesNothing) {
  Staging s(context);
  ASSERT_FALSE(s.admit(upload_from("10.0.0.1"), 0));
  EXPECT_FALSE(s.add(0, true)) << "the router answers an upload without image";
  EXPECT_FALSE(s.finish());
  EXPECT_TRUE(s.file().empty());
  EXPECT_TRUE(staged().empty());
}

TEST_F(UploadStaging, DestroyingRemovesTheStagingFolderAndFreesTheSlot) {
  std::optional<Staging> s(std::in_place, context);
  ASSERT_FALSE(s->admit(upload_from("10.0.0.1"), 1000));
  ASSERT_FALSE(feed(*s, png(64, 64), 1 << 20));
  const fs::path folder = fs::path(s->file()).parent_path();
  ASSERT_TRUE(fs::exists(s->file()));
  EXPECT_TRUE(Staging(context).admit(upload_from("10.0.0.2"), 1000)) << "the one slot is held";

  s.reset();
  EXPECT_FALSE(fs::exists(folder));
  EXPECT_TRUE(staged().empty());
  EXPECT_FALSE(Staging(context).admit(upload_from("10.0.0.2"), 1000)) << "the slot is free again";
}

}  // namespace
}  // namespace zoomwarp
