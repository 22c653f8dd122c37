// saliency=gbvs in an image version's model: gbvs.bin written at ingest, ICAZ's gbvs variant
// (same mesh and forest, the GBVS map and node means from it), curator edits painted into both
// maps and gbvs.bin carried over to the edit's version, a damaged gbvs.bin computed again in
// memory (and reported) without writing into the published version.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "warp/analysis/image_analysis.h"
#include "warp/analysis/method_files.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;

// The boats ingested with their model, then a region (the boats' right half) marked unimportant.
class GbvsModel : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    tiles::Store store(dir_->path() + "/store");
    tiles::IngestOptions options;
    options.analyse = [](const tiles::ImageEntry& staged) { warp::write_image_analysis(staged); };
    tiles::ingest_image(store, testing::samples_dir() + "/boats_lake_sunset.jpg", "b", options);
    original_ = new tiles::ImageEntry(*store.find("b"));
    warp::ModelEdit edit;
    edit.significance = {{{{1300, 800}, {2300, 800}, {2300, 1150}, {1300, 1150}}, 0.0f}};
    edited_ = new tiles::ImageEntry(*warp::edit_image_model(store, *original_, edit));
  }
  static void TearDownTestSuite() {
    delete edited_;
    delete original_;
    delete dir_;
  }

  warp::LoadedModel gbvs_model(const tiles::ImageEntry& e) {
    return warp::load_image_model(e, reader_, {}, {warp::Saliency::kGbvs, warp::LineSet::kCurator});
  }

  static testing::TempDir* dir_;
  static tiles::ImageEntry *original_, *edited_;
  testing::TempDir copies_;
  tiles::PyramidReader reader_{8 << 20};
};
testing::TempDir* GbvsModel::dir_ = nullptr;
tiles::ImageEntry* GbvsModel::original_ = nullptr;
tiles::ImageEntry* GbvsModel::edited_ = nullptr;

TEST_F(GbvsModel, IngestWritesGbvsAndIcazKeepsItsMeshWithTheGbvsMeans) {
  ASSERT_TRUE(fs::exists(original_->files->location() + "/" + warp::kGbvsFile));
  const warp::ImageModel by_default = warp::load_image_model(*original_, reader_).model;
  const warp::LoadedModel gbvs = gbvs_model(*original_);
  EXPECT_EQ(gbvs.source, warp::ModelSource::kStored);
  const warp::SignificanceMap stored = warp::read_gbvs_map(*original_);
  EXPECT_TRUE(gbvs.model.significance.values == stored.values) << "no edits: the map as stored";
  EXPECT_EQ(stored.width, by_default.significance.width);
  EXPECT_EQ(stored.height, by_default.significance.height);
  EXPECT_FALSE(stored.values == by_default.significance.values);
  ASSERT_EQ(gbvs.model.coarse.mesh.vertices.size(), by_default.coarse.mesh.vertices.size());
  for (std::size_t v = 0; v < by_default.coarse.mesh.vertices.size(); ++v) {
    EXPECT_EQ(gbvs.model.coarse.mesh.vertices[v].x, by_default.coarse.mesh.vertices[v].x);
    EXPECT_EQ(gbvs.model.coarse.mesh.vertices[v].y, by_default.coarse.mesh.vertices[v].y);
  }
  ASSERT_EQ(gbvs.model.forest.kept_nodes(), by_default.forest.kept_nodes());
  ASSERT_EQ(gbvs.model.node_mean.size(), by_default.node_mean.size());
  int different = 0;
  for (std::size_t n = 0; n < gbvs.model.node_mean.size(); ++n) different += gbvs.model.node_mean[n] != by_default.node_mean[n];
  EXPECT_GT(different, int(gbvs.model.node_mean.size()) / 2) << "node means from the GBVS map";
  EXPECT_TRUE(warp::saliency_map(*original_, reader_, by_default, warp::Saliency::kDefault).values ==
              by_default.significance.values);
}

TEST_F(GbvsModel, CuratorEditsApplyToTheGbvsMapAndItsFileIsCarriedOver) {
  EXPECT_EQ(testing::read_file(edited_->files->location() + "/" + warp::kGbvsFile), testing::read_file(original_->files->location() + "/" + warp::kGbvsFile));
  const warp::ImageModel before = gbvs_model(*original_).model, after = gbvs_model(*edited_).model;
  const double s = after.significance.scale;
  const int x = int(1800 * s), y = int(1000 * s);
  EXPECT_GT(before.significance.at(x, y), 0.0f) << "the boats are salient to GBVS";
  EXPECT_EQ(after.significance.at(x, y), 0.0f) << "the curator's region painted in";
  EXPECT_EQ(after.significance.at(int(300 * s), int(300 * s)), before.significance.at(int(300 * s), int(300 * s)));
  EXPECT_FALSE(before.node_mean == after.node_mean);
}

TEST_F(GbvsModel, ADamagedGbvsFileIsComputedAgainInMemoryAndReported) {
  const warp::ImageModel intact = gbvs_model(*edited_).model;
  for (const std::string damage : {"truncated", "flipped", "deleted"}) {
    SCOPED_TRACE(damage);
    const tiles::ImageEntry c{edited_->manifest, tiles::folder_files(copies_.path() + "/" + damage)};
    fs::copy(edited_->files->location(), c.files->location());
    const std::string path = c.files->location() + "/" + warp::kGbvsFile;
    std::string bytes = testing::read_file(path);
    if (damage == "truncated") bytes.resize(bytes.size() / 2);
    if (damage == "flipped") bytes[bytes.size() / 2] ^= 0x10;
    if (damage == "deleted") fs::remove(path);
    else std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
    const warp::LoadedModel loaded = gbvs_model(c);
    if (damage == "deleted") {
      EXPECT_EQ(loaded.source, warp::ModelSource::kStored) << "a version not analysed for GBVS: nothing is damaged";
      // Computed on first use and kept with the version (issue 28): the very file ingest wrote.
      EXPECT_EQ(testing::read_file(path), bytes);
    } else {
      EXPECT_EQ(loaded.source, warp::ModelSource::kRebuiltWithEdits);
      EXPECT_EQ(loaded.damaged_file, warp::kGbvsFile);
      EXPECT_EQ(testing::read_file(path), bytes) << "never written into a published version";
    }
    EXPECT_TRUE(loaded.model.significance.values == intact.significance.values) << "the same map, edits painted";
    EXPECT_TRUE(loaded.model.node_mean == intact.node_mean);
  }
}

}  // namespace
}  // namespace zoomwarp
