// The model files kept with an image version under damage: each binary file truncated, flipped
// in the middle or deleted is rebuilt with the curator's lines and significance edits; a damaged
// or missing warp.json is refused (the edits cannot be recovered); files of the previous formats
// (no checksum trailer, float maps, uncompressed method files) are still read; a damaged
// compressed method file is precomputed again in memory.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "warp/analysis/deflated_payload.h"
#include "warp/analysis/detected_lines.h"
#include "warp/analysis/image_analysis.h"
#include "warp/analysis/method_files.h"
#include "warp/analysis/model_file.h"
#include "warp/lines/line_detection.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

enum class Damage { kTruncate, kFlipMiddle, kDelete, kGarbage };

const char* name(Damage d) {
  switch (d) {
    case Damage::kTruncate: return "truncated";
    case Damage::kFlipMiddle: return "flipped in the middle";
    case Damage::kDelete: return "deleted";
    case Damage::kGarbage: return "replaced with garbage";
  }
  return "";
}

void damage(const std::string& path, Damage d) {
  std::string bytes = testing::read_file(path);
  switch (d) {
    case Damage::kTruncate: bytes.resize(bytes.size() * 2 / 3); break;
    case Damage::kFlipMiddle:
      for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 4; ++i) bytes[i] = char(~bytes[i]);
      break;
    case Damage::kDelete: fs::remove(path); return;
    case Damage::kGarbage: bytes = "{\"lines\": [[1, 2"; break;
  }
  write_bytes(path, bytes);
}

// One image ingested with its model, then edited by a curator (a line and two regions).
class ModelFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    tiles::Store store(dir_->path() + "/store");
    tiles::IngestOptions options;
    options.analyse = [](const tiles::ImageEntry& staged) { warp::write_image_analysis(staged); };
    tiles::ingest_image(store, testing::samples_dir() + "/boats_lake_sunset.jpg", "b", options);
    warp::ModelEdit edit;
    edit.lines = std::vector<warp::Segment>{{{0, 1000}, {2560, 1000}}};
    edit.significance = {{{{1800, 200}, {2300, 200}, {2300, 600}, {1800, 600}}, 1.0f},
                         {{{100, 1200}, {700, 1200}, {700, 1500}}, 0.0f}};
    edited_ = new tiles::ImageEntry(*warp::edit_image_model(store, *store.find("b"), edit));
  }
  static void TearDownTestSuite() {
    delete edited_;
    delete dir_;
  }

  // A copy of the edited version's folder to damage.
  tiles::ImageEntry copy() {
    tiles::ImageEntry c{edited_->manifest, tiles::folder_files(copies_.path() + "/" + std::to_string(next_++))};
    fs::copy(edited_->files->location(), c.files->location());
    return c;
  }

  static testing::TempDir* dir_;
  static tiles::ImageEntry* edited_;
  testing::TempDir copies_;
  int next_ = 0;
  tiles::PyramidReader reader_{8 << 20};
};
testing::TempDir* ModelFiles::dir_ = nullptr;
tiles::ImageEntry* ModelFiles::edited_ = nullptr;

TEST_F(ModelFiles, IntactFilesAreReadAsStored) {
  const warp::LoadedModel loaded = warp::load_image_model(*edited_, reader_);
  EXPECT_EQ(loaded.source, warp::ModelSource::kStored);
  EXPECT_EQ(loaded.model.lines.size(), 1u);
  EXPECT_EQ(loaded.model.edits.size(), 2u);
}

TEST_F(ModelFiles, ADamagedBinaryFileIsRebuiltWithTheCuratorsLinesAndEdits) {
  const warp::ImageModel stored = warp::read_image_model(*edited_);
  for (const char* file : {warp::kSignificanceFile, warp::kModelFile})
    for (Damage d : {Damage::kTruncate, Damage::kFlipMiddle, Damage::kDelete}) {
      SCOPED_TRACE(std::string(file) + " " + name(d));
      const tiles::ImageEntry c = copy();
      damage(c.files->location() + "/" + file, d);
      EXPECT_THROW(warp::read_image_model(c), warp::ModelFileError);
      const warp::LoadedModel loaded = warp::load_image_model(c, reader_);
      EXPECT_EQ(loaded.source, warp::ModelSource::kRebuiltWithEdits);
      EXPECT_EQ(loaded.damaged_file, file);
      const warp::ImageModel& m = loaded.model;
      ASSERT_EQ(m.lines.size(), 1u);
      EXPECT_EQ(m.lines[0].a.y, 1000);
      ASSERT_EQ(m.edits.size(), 2u);
      EXPECT_EQ(m.coarse.line_vertices.size(), 1u) << "the line is in the rebuilt mesh";
      // The same map as the one stored: recomputed from the pyramid, the regions painted in.
      ASSERT_EQ(m.significance.values.size(), stored.significance.values.size());
      EXPECT_TRUE(m.significance.values == stored.significance.values);
      EXPECT_TRUE(m.node_mean == stored.node_mean);
      const double s = m.significance.scale;
      EXPECT_EQ(m.significance.at(int(2000 * s), int(400 * s)), 1.0f) << "the region marked important";
      EXPECT_EQ(m.significance.at(int(600 * s), int(1250 * s)), 0.0f) << "the region marked unimportant";
    }
}

TEST_F(ModelFiles, ADamagedOrMissingWarpJsonIsRefusedNotRebuiltWithoutTheEdits) {
  for (Damage d : {Damage::kTruncate, Damage::kFlipMiddle, Damage::kDelete, Damage::kGarbage}) {
    SCOPED_TRACE(name(d));
    const tiles::ImageEntry c = copy();
    damage(c.files->location() + "/" + warp::kModelJsonFile, d);
    try {
      warp::load_image_model(c, reader_);
      ADD_FAILURE() << "a model without the curator's edits was served";
    } catch (const warp::ModelFileError& e) {
      EXPECT_EQ(e.file(), warp::kModelJsonFile);
      EXPECT_EQ(std::string(e.what()).find(c.files->location()), std::string::npos) << "names the file, not its folder";
    }
  }
}

TEST_F(ModelFiles, NoModelFilesAtAllIsAVersionFromBeforeModelsAndIsBuilt) {
  const tiles::ImageEntry c = copy();
  for (const char* file : {warp::kSignificanceFile, warp::kModelFile, warp::kModelJsonFile}) fs::remove(c.files->location() + "/" + file);
  const warp::LoadedModel loaded = warp::load_image_model(c, reader_);
  EXPECT_EQ(loaded.source, warp::ModelSource::kBuiltNoFiles);
  EXPECT_TRUE(loaded.model.lines.empty());
  EXPECT_GT(loaded.model.forest.kept_nodes(), 0);
  // Made on first use and kept with the version (issue 28): the next load reads the same model.
  const warp::LoadedModel again = warp::load_image_model(c, reader_);
  EXPECT_EQ(again.source, warp::ModelSource::kStored);
  EXPECT_TRUE(again.model.node_mean == loaded.model.node_mean);
  EXPECT_TRUE(again.model.significance.values == loaded.model.significance.values);
}

// A map file of the float formats: magic, width, height, scale, a float per value; format 2 with
// the trailer, format 1 without.
std::string float_map_file(const char* magic, const warp::SignificanceMap& m, bool trailer) {
  std::string bytes(magic);
  bytes.resize(8, '\0');
  const std::int32_t size[2] = {m.width, m.height};
  bytes.append(reinterpret_cast<const char*>(size), sizeof size);
  bytes.append(reinterpret_cast<const char*>(&m.scale), sizeof m.scale);
  bytes.append(reinterpret_cast<const char*>(m.values.data()), m.values.size() * sizeof(float));
  return trailer ? warp::with_trailer(bytes) : bytes;
}

// The formats before the compact files (issue 28) are still read: significance.bin as floats with
// (format 2) and without (format 1) the trailer, warp_model.bin without it (format 1: '1' in the
// magic), gbvs.bin as floats, and the methods' files uncompressed (their own magic first).
TEST_F(ModelFiles, FilesOfThePreviousFormatsAreStillRead) {
  const warp::ImageModel stored = warp::read_image_model(*edited_);
  for (const char* magic : {"ZWSIG1", "ZWSIG2"}) {
    SCOPED_TRACE(magic);
    const tiles::ImageEntry c = copy();
    write_bytes(c.files->location() + "/" + warp::kSignificanceFile, float_map_file(magic, stored.significance, magic[5] == '2'));
    std::string bytes = testing::read_file(c.files->location() + "/" + warp::kModelFile);
    bytes.resize(bytes.size() - 12);  // the trailer: length + CRC-32
    ASSERT_EQ(bytes[7], '2');
    bytes[7] = '1';
    write_bytes(c.files->location() + "/" + warp::kModelFile, bytes);
    const warp::LoadedModel loaded = warp::load_image_model(c, reader_);
    EXPECT_EQ(loaded.source, warp::ModelSource::kStored);
    EXPECT_TRUE(loaded.model.node_mean == stored.node_mean);
    EXPECT_TRUE(loaded.model.significance.values == stored.significance.values);
  }
  const tiles::ImageEntry c = copy();
  const warp::SignificanceMap gbvs = warp::read_gbvs_map(*edited_);
  write_bytes(c.files->location() + "/" + warp::kGbvsFile, float_map_file("ZWGBVS1", gbvs, true));
  EXPECT_TRUE(warp::read_gbvs_map(c).values == gbvs.values);
  const warp::ImageModel model = warp::read_image_model(c);
  for (const char* name : {"seam", "patch"}) {
    SCOPED_TRACE(name);
    const warp::RetargetingMethod& method = *warp::find_retargeting_method(name);
    const std::string file = warp::method_file_name(method, warp::Saliency::kDefault);
    const std::string payload = warp::method_payload(file, testing::read_file(c.files->location() + "/" + file), method);
    write_bytes(c.files->location() + "/" + file, warp::with_trailer(std::string(method.magic.begin(), method.magic.end()) + payload));
    EXPECT_EQ(warp::method_payload(file, testing::read_file(c.files->location() + "/" + file), method), payload);
    EXPECT_EQ(warp::load_retargeter(c, reader_, model, method, warp::Saliency::kDefault).source,
              warp::MethodSource::kStored);
  }
}

// A method's compressed file that is damaged — a flip the trailer's CRC-32 catches before the
// stream is inflated, a truncation, another method's file under its name — is precomputed again
// in memory and reported, never written into the version, as damaged files were before.
TEST_F(ModelFiles, ADamagedCompressedMethodFileIsPrecomputedAgainInMemory) {
  const warp::ImageModel model = warp::read_image_model(*edited_);
  const warp::RetargetingMethod& seam = *warp::find_retargeting_method("seam");
  const std::string file = warp::method_file_name(seam, warp::Saliency::kDefault);
  EXPECT_EQ(warp::load_retargeter(*edited_, reader_, model, seam, warp::Saliency::kDefault).source,
            warp::MethodSource::kStored);
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE(k);
    const tiles::ImageEntry c = copy();
    const std::string path = c.files->location() + "/" + file;
    if (k < 2) damage(path, k == 0 ? Damage::kFlipMiddle : Damage::kTruncate);
    else fs::copy_file(c.files->location() + "/patch.default.bin", path, fs::copy_options::overwrite_existing);
    const std::string before = testing::read_file(path);
    const warp::LoadedRetargeter loaded = warp::load_retargeter(c, reader_, model, seam, warp::Saliency::kDefault);
    EXPECT_EQ(loaded.source, warp::MethodSource::kRebuiltDamaged);
    EXPECT_EQ(loaded.reason.rfind(file, 0), 0u) << loaded.reason;
    EXPECT_TRUE(loaded.engine);
    EXPECT_EQ(testing::read_file(path), before) << "never written into a published version";
  }
}

// A method file of another format — written by a release before a method's format changed (issue
// 30 changed polyfem's and mp's) — is precomputed again and replaced by the current format, not
// rebuilt in memory on every load as a damaged one is.
TEST_F(ModelFiles, AMethodFileOfAnotherFormatIsPrecomputedAgainAndReplaced) {
  const warp::ImageModel model = warp::read_image_model(*edited_);
  const warp::RetargetingMethod& seam = *warp::find_retargeting_method("seam");
  const std::string file = warp::method_file_name(seam, warp::Saliency::kDefault);
  const tiles::ImageEntry c = copy();
  const std::string path = c.files->location() + "/" + file;
  const std::string payload = warp::method_payload(file, testing::read_file(path), seam);
  std::string old_magic(seam.magic.begin(), seam.magic.end());
  ASSERT_EQ(old_magic[6], '1');
  old_magic[6] = '0';
  write_bytes(path, warp::with_trailer(std::string("ZWDEFL2\0", 8) + old_magic + warp::deflated(payload)));
  EXPECT_THROW(warp::method_payload(file, testing::read_file(path), seam), warp::OutdatedMethodFile);

  const warp::LoadedRetargeter loaded = warp::load_retargeter(c, reader_, model, seam, warp::Saliency::kDefault);
  EXPECT_EQ(loaded.source, warp::MethodSource::kBuiltInMemory);
  EXPECT_TRUE(loaded.stored);
  EXPECT_EQ(warp::method_payload(file, testing::read_file(path), seam), payload) << "replaced in the current format";
  EXPECT_EQ(warp::load_retargeter(c, reader_, model, seam, warp::Saliency::kDefault).source, warp::MethodSource::kStored);
}

TEST_F(ModelFiles, AChecksumCatchesAFlipThatParsesAndAFileOfAnotherImageIsRefused) {
  // A flip inside the significance values still parses as floats: only the checksum sees it.
  tiles::ImageEntry c = copy();
  std::string bytes = testing::read_file(c.files->location() + "/" + warp::kSignificanceFile);
  bytes[bytes.size() / 2] ^= 0x01;
  write_bytes(c.files->location() + "/" + warp::kSignificanceFile, bytes);
  EXPECT_THROW(warp::read_significance(c), warp::ModelFileError);

  tiles::ImageEntry other = copy();
  other.manifest.width /= 2;
  try {
    warp::read_image_model(other);
    ADD_FAILURE() << "a model of another image size was read";
  } catch (const warp::ModelFileError& e) {
    EXPECT_NE(std::string(e.what()).find("another image size"), std::string::npos) << e.what();
  }
}

// lines.detected.json is derived data: written at ingest, carried into the edited version, and
// when damaged, missing or from another detector the lines are detected again in memory — the
// same lines — without writing into the version.
TEST_F(ModelFiles, ADamagedOrMissingDetectedLinesFileIsDetectedAgain) {
  ASSERT_TRUE(fs::exists(edited_->files->location() + "/" + warp::kDetectedLinesFile)) << "carried into the edited version";
  const std::vector<warp::Segment> stored = warp::read_detected_lines(*edited_, reader_);
  ASSERT_FALSE(stored.empty());
  const auto other_detector = [](const std::string& path) {
    std::string text = testing::read_file(path);
    text.replace(text.find("canny+houghp/1"), 14, "canny+houghp/0");
    write_bytes(path, text);
  };
  for (int k = 0; k < 5; ++k) {
    SCOPED_TRACE(k < 4 ? name(Damage(k)) : "from another detector");
    const tiles::ImageEntry c = copy();
    const std::string path = c.files->location() + "/" + warp::kDetectedLinesFile;
    if (k < 4) damage(path, Damage(k));
    else other_detector(path);
    const std::string before = fs::exists(path) ? testing::read_file(path) : "";
    const auto again = warp::read_detected_lines(c, reader_);
    ASSERT_EQ(again.size(), stored.size());
    for (std::size_t i = 0; i < again.size(); ++i) EXPECT_TRUE(warp::same_segment(again[i], stored[i], 0.01)) << i;
    if (k == int(Damage::kDelete))  // never detected for this version: detected on first use and kept (issue 28)
      EXPECT_EQ(testing::read_file(path), testing::read_file(edited_->files->location() + "/" + warp::kDetectedLinesFile));
    else
      EXPECT_EQ(fs::exists(path) ? testing::read_file(path) : "", before) << "a damaged file is left as it is";
  }
}

// The dismissed suggestions are the curator's: warp.json keeps them, a rebuilt model too, and a
// warp.json from before line detection (no "dismissed_lines") reads as none dismissed.
TEST_F(ModelFiles, DismissedLinesLiveInWarpJson) {
  const tiles::ImageEntry c = copy();
  warp::ImageModel model = warp::read_image_model(c);
  EXPECT_TRUE(model.dismissed_lines.empty());
  const std::vector<warp::Segment> suggested = warp::suggested_lines(c, reader_, model);
  ASSERT_FALSE(suggested.empty());
  model.dismissed_lines = {suggested[0]};
  warp::write_image_model(*c.files, model);
  EXPECT_TRUE(warp::same_segment(warp::read_image_model(c).dismissed_lines.at(0), suggested[0], 0));
  const auto left = warp::suggested_lines(c, reader_, warp::read_image_model(c));
  EXPECT_EQ(left.size(), suggested.size() - 1);
  damage(c.files->location() + "/" + warp::kModelFile, Damage::kFlipMiddle);
  const warp::LoadedModel rebuilt = warp::load_image_model(c, reader_);
  ASSERT_EQ(rebuilt.source, warp::ModelSource::kRebuiltWithEdits);
  EXPECT_EQ(rebuilt.model.dismissed_lines.size(), 1u);

  const tiles::ImageEntry old = copy();
  nlohmann::json stored = nlohmann::json::parse(testing::read_file(old.files->location() + "/" + warp::kModelJsonFile));
  ASSERT_EQ(stored.erase("dismissed_lines"), 1u);
  write_bytes(old.files->location() + "/" + warp::kModelJsonFile, stored.dump(2));
  EXPECT_TRUE(warp::read_image_model(old).dismissed_lines.empty());
  EXPECT_EQ(warp::suggested_lines(old, reader_, warp::read_image_model(old)).size(), suggested.size());
}

}  // namespace
}  // namespace zoomwarp
