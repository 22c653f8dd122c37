// The image store on a bucket (tiles/bucket_store.h) through the public Store API, against
// OpenStack Swift's s3api on loopback (tests/support/swift_s3.h; suite S3Store, one process):
// two Store objects with their own local folders stand for two replicas that share nothing but
// the bucket. What a folder store guarantees holds here too: a version published on one is read
// whole on the other, a removal is seen, an analysis added by one is read by the other, and a
// commit that fails half-way publishes nothing and leaves only orphans the collector removes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "tests/support/server_process.h"
#include "tests/support/swift_s3.h"
#include "tests/support/stored_tile_reference.h"
#include "tiles/ingest.h"
#include "tiles/pyramid_builder.h"
#include "tiles/pyramid_reader.h"
#include "tiles/stored_tiles.h"
#include "tiles/s3_client.h"
#include "tiles/store.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using test::SwiftS3;

class S3Store : public ::testing::Test {
 protected:
  void SetUp() override {
    SwiftS3& s3 = SwiftS3::shared();
    for (const auto& [k, v] : s3.environment()) ::setenv(k.c_str(), v.c_str(), 1);
    bucket_ = s3.new_bucket("store");
    location_ = "s3://" + bucket_ + "/imgs";
  }

  // A Store as a replica would open it: its own local folder (staging, a disk cache of
  // `disk_bytes`), pointers read on every find().
  std::unique_ptr<tiles::Store> replica(const std::string& dir, std::uint64_t disk_bytes = 64ULL << 20) {
    return std::make_unique<tiles::Store>(location_, std::chrono::milliseconds(0),
                                          tiles::BucketStoreOptions{.dir = dir, .disk_bytes = disk_bytes, .memory_bytes = 32u << 20, .lease = {}});
  }

  // The whole of a version's file, read by range.
  static std::string whole(const tiles::ImageEntry& e, const std::string& name) {
    const auto file = e.files->open(name);
    if (!file) return "(missing)";
    std::string bytes(file->size(), '\0');
    EXPECT_EQ(file->read(0, bytes.size(), bytes.data()), bytes.size());
    return bytes;
  }

  // Every key of the bucket under the store's prefix.
  std::vector<std::string> keys(const std::string& under = "imgs/") {
    tiles::S3Client client(tiles::S3Config::from_environment());
    std::vector<std::string> out;
    for (const auto& e : client.list(bucket_, under, "", "", std::chrono::steady_clock::now() + std::chrono::seconds(20)).objects)
      out.push_back(e.key);
    return out;
  }

  std::string bucket_, location_;
  testing::TempDir a_dir_, b_dir_;
};

TEST_F(S3Store, AVersionPublishedOnOneReplicaIsReadWholeOnAnother) {
  auto a = replica(a_dir_.path()), b = replica(b_dir_.path());
  const tiles::Manifest m = tiles::ingest_image(*a, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", {});
  const auto on_b = b->find("boats");
  ASSERT_TRUE(on_b) << "published on a, not found on b";
  EXPECT_EQ(on_b->manifest.version, m.version);
  EXPECT_EQ(on_b->manifest.levels, m.levels);
  EXPECT_EQ(b->list().size(), 1u);
  const auto on_a = a->find("boats");
  for (int k = 0; k < m.levels; ++k)
    EXPECT_EQ(whole(*on_b, tiles::level_filename(k)), whole(*on_a, tiles::level_filename(k))) << "level " << k;
  EXPECT_FALSE(on_b->files->local_path(tiles::level_filename(0))) << "no local copy of a level file is made";
}

// Issue 29, "reads that suit an object store": a level's header and tile index are read once,
// then a tile costs one ranged GET, and no level file is downloaded whole.
TEST_F(S3Store, ATileCostsOneRangedGetOnceItsLevelIsOpen) {
  auto a = replica(a_dir_.path());
  tiles::ingest_image(*a, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", {});
  auto b = replica(b_dir_.path());
  const auto e = b->find("boats");
  ASSERT_TRUE(e && tiles::has_jpeg_tiles(e->manifest));
  const std::uint64_t level_bytes = e->files->open(tiles::level_filename(0))->size();
  tiles::StoredTiles stored;
  const auto before = b->stats().requests;
  const std::string first = stored.jpeg_tile(*e, 0, 0, 0);
  const auto opened = b->stats().requests;
  const std::string far = stored.jpeg_tile(*e, 0, 9, 5);  // another tile, blocks away from the first
  const auto after = b->stats().requests;
  using Op = tiles::S3Operation;
  auto n = [](const tiles::S3Stats& s, Op op) { return s.requests[std::size_t(op)]; };
  EXPECT_EQ(n(after, Op::kGet), n(before, Op::kGet)) << "no level file fetched whole";
  EXPECT_LE(n(opened, Op::kGetRange) - n(before, Op::kGetRange), 3u) << "header, tile index and the first tile";
  EXPECT_EQ(n(after, Op::kGetRange) - n(opened, Op::kGetRange), 1u) << "one ranged GET for a further tile";
  EXPECT_EQ(n(after, Op::kHead) - n(opened, Op::kHead), 0u);
  EXPECT_LT(after.bytes_received - before.bytes_received, level_bytes / 4) << "a small part of the " << level_bytes
                                                                           << "-byte level was read";
  const std::string again = stored.jpeg_tile(*e, 0, 9, 5);
  EXPECT_EQ(n(b->stats().requests, Op::kGetRange), n(after, Op::kGetRange)) << "a tile read again comes from the cache";
  EXPECT_EQ(again, far);
  testing::TempDir copy;
  std::ofstream(copy.path() + "/level.tif", std::ios::binary) << whole(*e, tiles::level_filename(0));
  EXPECT_EQ(far, testing::stored_tile_jpeg(copy.path() + "/level.tif", 9, 5)) << "the bytes libtiff reads from the file";
}

// The disk tier: kept across a restart (a replica starts warm), and within its bound.
TEST_F(S3Store, TheDiskCacheOutlivesTheProcessAndStaysWithinItsBound) {
  auto a = replica(a_dir_.path());
  tiles::ingest_image(*a, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", {});
  const std::uint64_t bound = 4u << 20;
  std::vector<std::uint8_t> pixels;
  {
    auto b = replica(b_dir_.path(), bound);
    tiles::PyramidReader reader(8u << 20);
    const auto e = b->find("boats");
    pixels = reader.read_level(*e, 1, tiles::Rect{0, 0, 1280, 800}).pixels;
    EXPECT_GT(b->stats().cache.disk_bytes, 0u);
    EXPECT_LE(b->stats().cache.disk_bytes, bound);
  }
  std::uint64_t on_disk = 0;
  for (const auto& f : fs::recursive_directory_iterator(b_dir_.path() + "/ranges"))
    if (f.is_regular_file()) on_disk += f.file_size();
  EXPECT_GT(on_disk, 0u);
  EXPECT_LE(on_disk, bound);
  auto restarted = replica(b_dir_.path(), bound);
  tiles::PyramidReader reader(8u << 20);
  const auto e = restarted->find("boats");
  const auto before = restarted->stats();
  EXPECT_EQ(reader.read_level(*e, 1, tiles::Rect{0, 0, 1280, 800}).pixels, pixels);
  const auto after = restarted->stats();
  EXPECT_GT(after.cache.disk_hits, before.cache.disk_hits) << "read from the folder the last process filled";
  EXPECT_LT(after.requests.requests[std::size_t(tiles::S3Operation::kGetRange)] -
                before.requests.requests[std::size_t(tiles::S3Operation::kGetRange)],
            10u);
}

TEST_F(S3Store, ARemovalAndAnAddedAnalysisAreSeenByTheOtherReplica) {
  auto a = replica(a_dir_.path()), b = replica(b_dir_.path());
  tiles::ingest_image(*a, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", {});
  ASSERT_TRUE(b->find("boats"));
  EXPECT_FALSE(b->find("boats")->files->exists("lines.json"));
  a->find("boats")->files->write("lines.json", "{\"lines\": []}");
  EXPECT_EQ(b->find("boats")->files->read("lines.json"), std::optional<std::string>("{\"lines\": []}"));
  EXPECT_TRUE(a->remove("boats"));
  EXPECT_FALSE(b->find("boats"));
  EXPECT_FALSE(b->published("boats"));
  EXPECT_FALSE(b->remove("boats"));
}

// An edit's new version takes the files it does not change by a copy inside the bucket: no level
// file's bytes come down to the replica or go up again (issue 42; before, a label edit moved the
// whole pyramid both ways).
TEST_F(S3Store, AnEditCopiesTheFilesItKeepsInsideTheBucket) {
  auto a = replica(a_dir_.path());
  tiles::ingest_image(*a, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", {});
  const auto before_edit = a->find("boats");
  const std::uint64_t level_bytes = before_edit->files->open(tiles::level_filename(0))->size();
  const auto before = a->stats().requests;
  const std::string staging = a->make_staging_copy(*before_edit);
  tiles::folder_files(staging)->write("description.json", R"({"label": {"none": ["Boats"]}})");
  const auto edited = a->publish(staging, before_edit->manifest, &before_edit->manifest.version);
  const auto after = a->stats().requests;
  using Op = tiles::S3Operation;
  auto n = [](const tiles::S3Stats& s, Op op) { return s.requests[std::size_t(op)]; };
  EXPECT_EQ(n(after, Op::kCopy) - n(before, Op::kCopy), std::uint64_t(before_edit->manifest.levels))
      << "each level copied inside the bucket";
  EXPECT_EQ(n(after, Op::kGetRange), n(before, Op::kGetRange)) << "no level read";
  EXPECT_LT(after.bytes_received - before.bytes_received + after.bytes_sent - before.bytes_sent, level_bytes / 4);
  auto b = replica(b_dir_.path());
  const auto on_b = b->find("boats");
  ASSERT_TRUE(on_b);
  EXPECT_EQ(on_b->manifest.version, edited->manifest.version);
  EXPECT_EQ(on_b->files->read("description.json").value_or(""), R"({"label": {"none": ["Boats"]}})");
  for (int k = 0; k < on_b->manifest.levels; ++k)
    EXPECT_EQ(whole(*on_b, tiles::level_filename(k)), whole(*before_edit, tiles::level_filename(k))) << "level " << k;
  EXPECT_FALSE(on_b->files->exists(".copied-in-store")) << "the list is the staging folder's, not the version's";
}

TEST_F(S3Store, ACommitThatFailsPublishesNothingAndItsOrphansAreCollected) {
  auto a = replica(a_dir_.path()), b = replica(b_dir_.path());
  tiles::ingest_image(*a, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", {});
  const std::string published = a->find("boats")->manifest.version;
  // A staged version with a file that cannot be read: the upload stops at it, after others.
  const std::string staging = a->make_staging_copy(*a->find("boats"));
  fs::create_symlink("/nonexistent/zoomwarp", fs::path(staging) / "zz_unreadable.bin");
  EXPECT_ANY_THROW(a->publish(staging, a->find("boats")->manifest));
  EXPECT_FALSE(fs::exists(staging)) << "the staging folder is discarded";
  EXPECT_EQ(b->find("boats")->manifest.version, published) << "the old version is still the one read";
  std::size_t version_dirs = 0;
  for (const std::string& k : keys("imgs/versions/"))
    if (k.ends_with("/level_0.tif")) ++version_dirs;
  EXPECT_EQ(version_dirs, 2u) << "the cut commit's files are in the bucket, unnamed by any pointer";
  EXPECT_EQ(b->collect_garbage(std::chrono::seconds(0)), 1);
  for (const std::string& k : keys("imgs/versions/"))
    EXPECT_TRUE(k.starts_with("imgs/versions/boats@" + published + "/")) << k << " left behind";
  EXPECT_TRUE(b->find("boats"));
}

// `zoomwarp store copy` from a folder to the bucket and back: the same images, the same versions,
// the same bytes; a second run copies nothing.
TEST_F(S3Store, StoreCopyRoundTripsAFolderStoreThroughABucket) {
  testing::TempDir folders;
  const std::string a = folders.path() + "/a", c = folders.path() + "/c";
  {
    tiles::Store store(a);
    tiles::ingest_image(store, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", {});
    tiles::ingest_image(store, testing::samples_dir() + "/interior_wine_djembe_tall.jpg", "interior", {});
    store.find("boats")->files->write("lines.json", "{\"lines\": []}");  // an analysis goes too
  }
  const auto there = testing::run_command({testing::zoomwarp_binary(), "store", "copy", a, location_});
  const auto back = testing::run_command({testing::zoomwarp_binary(), "store", "copy", location_, c});
  const auto again = testing::run_command({testing::zoomwarp_binary(), "store", "copy", a, location_});
  ASSERT_EQ(there.exit_code, 0) << there.output;
  ASSERT_EQ(back.exit_code, 0) << back.output;
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(again.output.find("checked"), std::string::npos) << "nothing copied again:\n" << again.output;

  tiles::Store original(a), copy(c);
  const auto from = original.list(), to = copy.list();
  ASSERT_EQ(to.size(), 2u);
  for (std::size_t i = 0; i < from.size(); ++i) {
    EXPECT_EQ(to[i]->manifest.id, from[i]->manifest.id);
    EXPECT_EQ(to[i]->manifest.version, from[i]->manifest.version) << "versions kept";
    auto names = from[i]->files->names();
    auto copied = to[i]->files->names();
    std::sort(names.begin(), names.end()), std::sort(copied.begin(), copied.end());
    EXPECT_EQ(copied, names);
    for (const std::string& n : names)
      EXPECT_EQ(testing::read_file(*to[i]->files->local_path(n)), testing::read_file(*from[i]->files->local_path(n)))
          << from[i]->manifest.id << "/" << n;
  }
}

TEST_F(S3Store, StoreCopyRefusesBadArguments) {
  EXPECT_EQ(testing::run_command({testing::zoomwarp_binary(), "store", "copy", location_}).exit_code, 2);
  EXPECT_EQ(testing::run_command({testing::zoomwarp_binary(), "store", "copy", location_, location_}).exit_code, 2);
  EXPECT_EQ(testing::run_command({testing::zoomwarp_binary(), "store", "move", "a", "b"}).exit_code, 2);
  testing::TempDir empty;
  const auto missing = testing::run_command({testing::zoomwarp_binary(), "store", "copy", empty.path() + "/s", location_, "nope"});
  EXPECT_EQ(missing.exit_code, 1) << missing.output;
  EXPECT_NE(missing.output.find("nope: no such image"), std::string::npos) << missing.output;
}

TEST_F(S3Store, CredentialsThatAreRefusedStopTheStart) {
  ::setenv("AWS_SECRET_ACCESS_KEY", "wrong", 1);
  try {
    tiles::Store store(location_);
    ADD_FAILURE() << "a store opened with a wrong secret";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(location_), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace zoomwarp
