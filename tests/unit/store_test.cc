// The store's publishing protocol: atomic replacement, unpublishing, garbage collection.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "tests/support/server_process.h"
#include "tiles/image_id.h"
#include "tiles/store.h"
#include "tiles/superseded_versions.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

tiles::Manifest manifest(const std::string& id, int w = 100, int h = 50) {
  tiles::Manifest m;
  m.id = id;
  m.width = w;
  m.height = h;
  m.levels = tiles::pyramid_levels(w, h);
  return m;
}

TEST(ImageId, Validation) {
  for (const char* ok : {"a", "A1", "img-1.v2_final", "0"}) EXPECT_TRUE(tiles::is_valid_image_id(ok)) << ok;
  for (const char* bad : {"", ".", "..", "../etc", "a/b", "a\\b", "-a", "_a", ".a", "a..b", "a b", "a%2F", "é"})
    EXPECT_FALSE(tiles::is_valid_image_id(bad)) << bad;
  EXPECT_FALSE(tiles::is_valid_image_id(std::string("a\0b", 3)));
  EXPECT_FALSE(tiles::is_valid_image_id(std::string(129, 'a')));
  EXPECT_TRUE(tiles::is_valid_image_id(std::string(128, 'a')));
  EXPECT_EQ(tiles::image_id_from_filename("/x/y/My photo (1).JPG"), "My_photo_1");
  EXPECT_EQ(tiles::image_id_from_filename("..."), "");
}

TEST(Store, PublishReplaceRemove) {
  TempDir dir;
  tiles::Store store(dir.path());
  EXPECT_FALSE(store.find("a"));

  auto staging = store.make_staging_dir();
  auto v1 = store.publish(staging, manifest("a"));
  EXPECT_FALSE(fs::exists(staging));
  auto found = store.find("a");
  ASSERT_TRUE(found);
  EXPECT_EQ(found->manifest.version, v1->manifest.version);

  auto v2 = store.publish(store.make_staging_dir(), manifest("a", 200, 100));
  EXPECT_NE(v1->manifest.version, v2->manifest.version);
  EXPECT_EQ(store.find("a")->manifest.width, 200);
  EXPECT_TRUE(fs::exists(v1->files->location())) << "the old version stays for readers until garbage collection";
  ASSERT_EQ(store.list().size(), 1u);

  EXPECT_TRUE(store.remove("a"));
  EXPECT_FALSE(store.find("a"));
  EXPECT_FALSE(store.remove("a"));
  EXPECT_TRUE(store.list().empty());

  // A new Store on the same folder (a restarted server) sees what was published.
  store.publish(store.make_staging_dir(), manifest("b"));
  tiles::Store reopened(dir.path());
  ASSERT_TRUE(reopened.find("b"));
}

// A link once read is trusted for the recheck interval, but this process's own publish and remove
// take effect at once however long that interval is.
TEST(Store, OwnPublishAndRemoveAreSeenAtOnce) {
  TempDir dir;
  tiles::Store store(dir.path(), std::chrono::hours(1));
  auto v1 = store.publish(store.make_staging_dir(), manifest("a"));
  ASSERT_EQ(store.find("a")->manifest.version, v1->manifest.version);
  auto v2 = store.publish(store.make_staging_dir(), manifest("a", 200, 100));
  EXPECT_EQ(store.find("a")->manifest.version, v2->manifest.version);
  EXPECT_TRUE(store.remove("a"));
  EXPECT_FALSE(store.find("a"));
}

// Another process sharing the store (a second Store on the same folder): a new image is found at
// once, its replacement and removal once the reader's recheck interval has passed.
TEST(Store, AnotherProcessesChangesAreSeenWithinTheRecheckInterval) {
  TempDir dir;
  constexpr auto kRecheck = std::chrono::milliseconds(50);
  tiles::Store reader(dir.path(), kRecheck), trusting(dir.path(), std::chrono::hours(1)), every_time(dir.path(), {});
  tiles::Store writer(dir.path());
  EXPECT_FALSE(reader.find("a"));
  auto v1 = writer.publish(writer.make_staging_dir(), manifest("a"));
  ASSERT_TRUE(reader.find("a")) << "an id found missing is not remembered";
  EXPECT_EQ(reader.find("a")->manifest.version, v1->manifest.version);
  ASSERT_TRUE(trusting.find("a"));
  ASSERT_TRUE(every_time.find("a"));

  auto v2 = writer.publish(writer.make_staging_dir(), manifest("a", 200, 100));
  EXPECT_EQ(every_time.find("a")->manifest.version, v2->manifest.version);
  EXPECT_EQ(trusting.find("a")->manifest.version, v1->manifest.version) << "trusted until rechecked";
  std::this_thread::sleep_for(kRecheck);
  EXPECT_EQ(reader.find("a")->manifest.version, v2->manifest.version);

  ASSERT_TRUE(writer.remove("a"));
  EXPECT_FALSE(every_time.find("a"));
  std::this_thread::sleep_for(kRecheck);
  EXPECT_FALSE(reader.find("a"));
}

// Issue 42: a version stays for the grace after it stopped being published, whatever its age — a
// version published an hour ago and replaced now is kept for the grace from now.
TEST(Store, GarbageCollectionCountsTheGraceFromTheSupersedeNotTheCreation) {
  using tiles::Collect;
  const std::int64_t now = 10'000'000;
  const std::chrono::seconds grace(30), hour = std::chrono::hours(1);
  const std::int64_t hour_ago = now - 3'600'000;
  EXPECT_EQ(tiles::collect_verdict(true, hour_ago, hour_ago, now, grace), Collect::kKeep) << "named";
  EXPECT_EQ(tiles::collect_verdict(false, now - 1000, hour_ago, now, grace), Collect::kKeep) << "replaced 1 s ago";
  EXPECT_EQ(tiles::collect_verdict(false, now - 30'000, hour_ago, now, grace), Collect::kRemove) << "replaced 30 s ago";
  EXPECT_EQ(tiles::collect_verdict(false, std::nullopt, hour_ago, now, grace), Collect::kMark)
      << "unnamed, never marked (a replica died between the pointer and the mark): marked, not removed";
  EXPECT_EQ(tiles::collect_verdict(false, hour_ago, now - 1000, now, grace), Collect::kKeep)
      << "younger than the grace: a commit in flight, its pointer not written yet";
  EXPECT_EQ(tiles::collect_verdict(false, std::nullopt, std::nullopt, now, std::chrono::seconds(0)), Collect::kRemove)
      << "a grace of 0 keeps nothing unnamed";
  EXPECT_EQ(tiles::collect_verdict(false, hour_ago, std::nullopt, now, hour), Collect::kRemove);
  EXPECT_EQ(tiles::parse_superseded_mark(tiles::superseded_mark(now)), now);
  for (const char* bad : {"", "\n", "12a\n", "-5\n", "99999999999999999999\n"})
    EXPECT_FALSE(tiles::parse_superseded_mark(bad)) << bad;
}

TEST(Store, AReplacedVersionIsKeptForTheGraceFromItsReplacement) {
  TempDir dir;
  tiles::Store store(dir.path());
  auto first = store.publish(store.make_staging_dir(), manifest("a"));
  // Made an hour ago, as far as its age goes.
  const auto hour_ago = fs::file_time_type::clock::now() - std::chrono::hours(1);
  fs::last_write_time(first->files->location(), hour_ago);
  auto second = store.publish(store.make_staging_dir(), manifest("a"));
  EXPECT_EQ(store.collect_garbage(std::chrono::minutes(10)), 0) << "replaced now: kept for the grace";
  EXPECT_TRUE(fs::exists(first->files->location()));
  EXPECT_TRUE(fs::exists(dir.path() + "/superseded/a@" + first->manifest.version));
  EXPECT_EQ(store.collect_garbage(std::chrono::seconds(-1)), 1);
  EXPECT_FALSE(fs::exists(first->files->location()));
  EXPECT_FALSE(fs::exists(dir.path() + "/superseded/a@" + first->manifest.version)) << "its mark goes with it";
  EXPECT_TRUE(fs::exists(second->files->location()));
  // A version unnamed without a mark (a process that died between moving the pointer and marking
  // it) is marked by the first pass and kept for the grace from then.
  fs::create_directories(dir.path() + "/versions/b@0000000000a");
  fs::last_write_time(dir.path() + "/versions/b@0000000000a", hour_ago);
  EXPECT_EQ(store.collect_garbage(std::chrono::minutes(10)), 0);
  EXPECT_TRUE(fs::exists(dir.path() + "/superseded/b@0000000000a"));
  EXPECT_TRUE(fs::exists(dir.path() + "/versions/b@0000000000a"));
}

TEST(Store, GarbageCollectionKeepsLiveVersionsAndRemovesDeadStaging) {
  TempDir dir;
  tiles::Store store(dir.path());
  auto old_version = store.publish(store.make_staging_dir(), manifest("a"));
  auto live = store.publish(store.make_staging_dir(), manifest("a"));
  auto deleted = store.publish(store.make_staging_dir(), manifest("gone"));
  store.remove("gone");
  // A staging folder of a process that no longer exists (pid 1 is init and never ours; use an
  // impossible pid instead).
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  std::string h(host);
  std::replace(h.begin(), h.end(), '.', '_');
  fs::create_directories(dir.path() + "/staging/" + h + ".999999999.abc");
  const std::string mine = store.make_staging_dir();

  EXPECT_EQ(store.collect_garbage(std::chrono::hours(1)), 1) << "only the dead staging folder is old enough";
  EXPECT_TRUE(fs::exists(old_version->files->location()));
  EXPECT_EQ(store.collect_garbage(std::chrono::seconds(-1)), 2);
  EXPECT_FALSE(fs::exists(old_version->files->location()));
  EXPECT_FALSE(fs::exists(deleted->files->location()));
  EXPECT_TRUE(fs::exists(live->files->location()));
  EXPECT_TRUE(fs::exists(mine)) << "our own staging folder is in use";
  EXPECT_TRUE(store.find("a"));
}

TEST(Store, LinksThatPointOutsideAreIgnored) {
  TempDir dir;
  tiles::Store store(dir.path());
  fs::create_symlink("/etc", dir.path() + "/images/evil");
  fs::create_symlink("../versions/../../x", dir.path() + "/images/evil2");
  EXPECT_FALSE(store.find("evil"));
  EXPECT_FALSE(store.find("evil2"));
  EXPECT_TRUE(store.list().empty());
}

}  // namespace
}  // namespace zoomwarp
