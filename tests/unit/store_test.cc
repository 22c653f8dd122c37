// The store's publishing protocol: atomic replacement, unpublishing, garbage collection.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "tests/support/server_process.h"
#include "tiles/image_id.h"
#include "tiles/store.h"

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
