// The warp model kept with an image: the forest built at ingest and serialised, the model's
// files, and curator edits published as new versions.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "warp/icaz/icaz.h"
#include "warp/analysis/image_analysis.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using warp::Point;

tiles::Raster reduced(const std::string& file) {
  const tiles::Raster full = testing::load_image(testing::samples_dir() + "/" + file);
  const double f = std::min(1.0, 1024.0 / std::max(full.width, full.height));
  return testing::resize(full, int(full.width * f), int(full.height * f));
}

void ingest_with_analysis(tiles::Store& store, const std::string& file, const std::string& id) {
  tiles::IngestOptions options;
  options.analyse = [](const tiles::ImageEntry& staged) { warp::write_image_analysis(staged); };
  tiles::ingest_image(store, testing::samples_dir() + "/" + file, id, options);
}

bool same_corners(const warp::Forest& a, const warp::Forest& b, int n) {
  for (int k = 0; k < 3; ++k) {
    const Point &p = a.vertices()[a.corners(n)[k]], &q = b.vertices()[b.corners(n)[k]];
    if (p.x != q.x || p.y != q.y) return false;
  }
  return true;
}

TEST(Forest, BuiltToTheRuntimeAreaSerialisedAndLazyBeyond) {
  const auto cm = warp::build_coarse_mesh(2560, 1600, {});
  warp::Forest f(cm.mesh);
  f.build_levels(500, 1 << 18);
  EXPECT_EQ(f.kept_nodes(), f.node_count());
  for (int n = 0; n < f.node_count(); ++n) {
    if (f.is_split(n)) continue;
    ASSERT_LE(f.area(n), 500) << "every leaf is as small as a view at 100 % asks";
  }

  warp::Forest capped(cm.mesh);
  capped.build_levels(500, 5000);
  EXPECT_LE(capped.node_count(), 5000) << "the node budget holds";
  EXPECT_GT(capped.node_count(), capped.root_count());

  std::stringstream bytes;
  f.write(bytes);
  EXPECT_LT(bytes.str().size(), std::size_t(f.node_count()) * 3) << "4 bytes per split, 2 nodes per split";
  const warp::Forest back = warp::Forest::read(bytes, cm.mesh);
  ASSERT_EQ(back.node_count(), f.node_count());
  ASSERT_EQ(back.vertices().size(), f.vertices().size());
  for (int n = 0; n < f.node_count(); ++n) {
    ASSERT_TRUE(same_corners(f, back, n));
    ASSERT_EQ(back.parent(n), f.parent(n));
  }

  // Lazy nodes below the stored ones, forgotten and made again identically.
  int leaf = 0;
  while (f.is_split(leaf)) leaf = f.children(leaf)[0];
  const auto made = f.children(leaf);
  const warp::Forest with_lazy = f;
  f.forget_lazy_nodes();
  EXPECT_EQ(f.node_count(), f.kept_nodes());
  EXPECT_FALSE(f.is_split(leaf));
  EXPECT_EQ(f.children(leaf), made);
  EXPECT_TRUE(same_corners(f, with_lazy, made[0]) && same_corners(f, with_lazy, made[1]));

  std::stringstream damaged(bytes.str().substr(0, bytes.str().size() / 2));
  EXPECT_THROW(warp::Forest::read(damaged, cm.mesh), std::runtime_error);
}

TEST(ImageModel, WrittenAtIngestAndReadBackIdentically) {
  testing::TempDir dir;
  tiles::Store store(dir.path() + "/store");
  ingest_with_analysis(store, "boats_lake_sunset.jpg", "b");
  const auto entry = store.find("b");
  for (const char* f : {warp::kSignificanceFile, warp::kModelFile, warp::kModelJsonFile})
    EXPECT_TRUE(fs::exists(entry->files->location() + "/" + f)) << f;
  const warp::ImageModel m = warp::read_image_model(*entry);
  EXPECT_EQ(m.significance.width, 640);  // level 2 (640×400) is the first ≤ 1024 px
  EXPECT_DOUBLE_EQ(m.significance.scale, 0.25);
  for (float v : m.significance.values) ASSERT_TRUE(v >= 0 && v <= 1);
  EXPECT_GT(m.forest.kept_nodes(), 10 * m.forest.root_count()) << "the forest was built at ingest";
  EXPECT_EQ(m.node_mean.size(), std::size_t(m.forest.kept_nodes()));

  // Written again and read back, the model gives the very same views.
  tiles::ImageEntry copy{entry->manifest, tiles::folder_files(dir.path() + "/copy")};
  fs::create_directories(copy.files->location());
  warp::write_image_model(*copy.files, m);
  warp::Icaz a(m), b(warp::read_image_model(copy));
  for (double z : {0.0, 0.5, 1.0}) {
    warp::ViewRequest r;
    r.zoom = z, r.cx = 900, r.cy = 700;
    const auto va = a.view(r), vb = b.view(r);
    ASSERT_EQ(va.screen.size(), vb.screen.size());
    for (std::size_t i = 0; i < va.screen.size(); ++i) {
      ASSERT_EQ(va.screen[i].x, vb.screen[i].x);
      ASSERT_EQ(va.screen[i].y, vb.screen[i].y);
    }
  }
  std::ofstream(copy.files->location() + "/" + warp::kModelFile, std::ios::trunc) << "ZWMODEL1 and then nothing";
  EXPECT_THROW(warp::read_image_model(copy), std::runtime_error);
}

TEST(ImageModel, AFailingAnalysisFailsTheIngestAndLeavesNothing) {
  testing::TempDir dir;
  tiles::Store store(dir.path() + "/store");
  tiles::IngestOptions options;
  options.analyse = [](const tiles::ImageEntry&) { throw std::runtime_error("analysis failed"); };
  EXPECT_THROW(tiles::ingest_image(store, testing::samples_dir() + "/boats_lake_sunset.jpg", "b", options),
               tiles::IngestError);
  EXPECT_FALSE(store.find("b"));
  EXPECT_TRUE(fs::is_empty(dir.path() + "/store/staging"));
  EXPECT_TRUE(fs::is_empty(dir.path() + "/store/versions"));
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(ImageModel, AnEditIsANewVersionConditionalOnTheOneItStartedFrom) {
  testing::TempDir dir;
  tiles::Store store(dir.path() + "/store");
  ingest_with_analysis(store, "boats_lake_sunset.jpg", "b");
  const auto v1 = store.find("b");
  const std::string v1_json = read_text(v1->files->location() + "/" + warp::kModelJsonFile);

  warp::ModelEdit edit;
  edit.lines = std::vector<warp::Segment>{{{0, 1000}, {2560, 1000}}};
  edit.significance.push_back({{{1800, 200}, {2300, 200}, {2300, 600}, {1800, 600}}, 1.0f});
  const auto v2 = warp::edit_image_model(store, *v1, edit);
  EXPECT_NE(v2->manifest.version, v1->manifest.version);
  EXPECT_EQ(store.find("b")->manifest.version, v2->manifest.version);
  const warp::ImageModel m2 = warp::read_image_model(*v2);
  ASSERT_EQ(m2.lines.size(), 1u);
  EXPECT_EQ(m2.edits.size(), 1u);
  EXPECT_EQ(m2.coarse.line_vertices.size(), 1u);
  EXPECT_GE(m2.coarse.line_vertices[0].size(), 2u) << "the line is in the coarsest mesh";
  EXPECT_EQ(read_text(v1->files->location() + "/" + warp::kModelJsonFile), v1_json) << "the old version is untouched";
  EXPECT_TRUE(fs::equivalent(v1->level_path(0), v2->level_path(0))) << "the pyramid is shared, not copied";

  // A stale edit (from v1 again) and a bad one publish nothing.
  EXPECT_THROW(warp::edit_image_model(store, *v1, edit), tiles::VersionConflict);
  warp::ModelEdit bad;
  bad.significance.push_back({{{0, 0}, {10, 0}, {10, 10}}, 2.0f});
  EXPECT_THROW(warp::edit_image_model(store, *v2, bad), std::invalid_argument);
  bad.significance.clear();
  bad.lines = std::vector<warp::Segment>{{{0, 0}, {std::nan(""), 5}}};
  EXPECT_THROW(warp::edit_image_model(store, *v2, bad), std::invalid_argument);
  EXPECT_EQ(store.find("b")->manifest.version, v2->manifest.version);
  EXPECT_TRUE(fs::is_empty(dir.path() + "/store/staging"));
}

// A region marked important through the model (no re-ingest) is shown larger by the operator;
// a region far from it barely changes.
TEST(ImageModel, ASignificanceEditEnlargesTheMarkedRegionOnScreen) {
  warp::ImageModel m = warp::make_image_model(reduced("boats_lake_sunset.jpg"), 2560, 1600);
  warp::Icaz before(m);
  warp::add_significance_edits(m, {{{{1800, 200}, {2300, 200}, {2300, 600}, {1800, 600}}, 1.0f}});
  warp::Icaz after(m);
  warp::ViewRequest r;  // the whole image on a 3:4 screen: a strong squeeze
  r.zoom = 0, r.cx = 1280, r.cy = 800, r.screen_width = 360, r.screen_height = 480;
  const auto vb = before.view(r), va = after.view(r);
  auto width_on_screen = [](const warp::View& v, double x0, double x1, double y0, double y1) {
    double lo = 1e9, hi = -1e9;
    for (std::size_t i = 0; i < v.source.vertices.size(); ++i) {
      const Point& p = v.source.vertices[i];
      if (p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1) lo = std::min(lo, v.screen[i].x), hi = std::max(hi, v.screen[i].x);
    }
    return hi - lo;
  };
  const double grown = width_on_screen(va, 1850, 2250, 250, 550) / width_on_screen(vb, 1850, 2250, 250, 550);
  const double far = width_on_screen(va, 150, 550, 1100, 1500) / width_on_screen(vb, 150, 550, 1100, 1500);
  std::printf("[ figures ] marked region %.2fx wider on screen, far region %.2fx\n", grown, far);
  EXPECT_GT(grown, 1.3);
  EXPECT_NEAR(far, 1.0, 0.35);
}

}  // namespace
}  // namespace zoomwarp
