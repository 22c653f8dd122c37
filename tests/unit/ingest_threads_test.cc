// Ingest on many threads (--ingest-threads) stores exactly what ingest on one thread stores: the
// level files byte for byte (tiles are compressed in parallel but written in order, and nothing
// time-dependent is written into them) and the warp analysis's files (its parts run in parallel).
// Progress is still reported, in order, from the ingesting thread.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <thread>

#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "warp/analysis/image_analysis.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// Every file of the published version but the manifest (its version and time differ by design).
std::map<std::string, std::string> version_files(const tiles::ImageEntry& image) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::directory_iterator(image.files->location()))
    if (e.path().filename() != "manifest.json")
      files[e.path().filename().string()] = testing::read_file(e.path().string());
  return files;
}

tiles::IngestOptions on_threads(int threads, bool analysed) {
  tiles::IngestOptions options;
  options.pyramid.threads = threads;
  if (analysed)
    options.analyse = [threads](const tiles::ImageEntry& staged) { warp::write_image_analysis(staged, {}, threads); };
  return options;
}

void expect_same_files(const std::string& source, bool analysed, const std::string& compression) {
  TempDir dir;
  tiles::Store store(dir.path() + "/store");
  tiles::ingest_image(store, source, "one", on_threads(1, analysed));
  tiles::ingest_image(store, source, "many", on_threads(4, analysed));
  EXPECT_EQ(store.find("one")->manifest.compression, compression);
  const auto one = version_files(*store.find("one")), many = version_files(*store.find("many"));
  ASSERT_EQ(one.size(), many.size());
  EXPECT_TRUE(one.count("level_0.tif"));
  for (const auto& [name, bytes] : one) {
    ASSERT_TRUE(many.count(name)) << name;
    EXPECT_TRUE(bytes == many.at(name)) << name << " differs between 1 and 4 threads";
  }
}

// The demo photograph, RGB JPEG decoded straight into the strips and stored as JPEG tiles (each
// compressed by its thread's own libjpeg compressor, the same bytes on any): 10×7 tiles at level
// 0, edge tiles at every level below; with the ICAZ model, the detected lines, the GBVS map and
// every method's file.
TEST(IngestThreads, SameFilesOnOneAndFourThreads) {
  expect_same_files(testing::samples_dir() + "/boats_lake_sunset.jpg", true, "jpeg");
}

// RGBA (straight alpha), 2048×512: a single strip of 8 tiles at level 0, levels of one strip.
TEST(IngestThreads, SameLevelsForRgbaOnOneAndFourThreads) {
  expect_same_files(testing::samples_dir() + "/pano_grossmugl_field_4to1.png", false, "zip:1");
}

TEST(IngestThreads, ProgressComesInOrderFromTheIngestingThread) {
  TempDir dir;
  tiles::Store store(dir.path() + "/store");
  std::vector<double> seen;
  const auto caller = std::this_thread::get_id();
  bool other_thread = false;
  tiles::ingest_image(store, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", on_threads(4, true),
                      [&](double f) {
                        seen.push_back(f);
                        other_thread |= std::this_thread::get_id() != caller;
                      });
  ASSERT_GT(seen.size(), 10u) << "a step per chunk of decoded rows";
  EXPECT_FALSE(other_thread);
  for (std::size_t i = 1; i < seen.size(); ++i) EXPECT_LE(seen[i - 1], seen[i]) << "step " << i;
  EXPECT_EQ(seen.back(), 1.0);
}

}  // namespace
}  // namespace zoomwarp
