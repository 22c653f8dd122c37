// The store's publishing protocol: atomic replacement, unpublishing, garbage collection.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

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
  EXPECT_TRUE(fs::exists(v1->dir)) << "the old version stays for readers until garbage collection";
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
  EXPECT_TRUE(fs::exists(old_version->dir));
  EXPECT_EQ(store.collect_garbage(std::chrono::seconds(-1)), 2);
  EXPECT_FALSE(fs::exists(old_version->dir));
  EXPECT_FALSE(fs::exists(deleted->dir));
  EXPECT_TRUE(fs::exists(live->dir));
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
