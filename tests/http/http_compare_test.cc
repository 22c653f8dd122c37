// `zoomwarp compare` as a user runs it: an image file in, a contact sheet and a metrics table
// (JSON and Markdown) out; the same result from a stored image; exit code 2 and a message for
// bad arguments, naming the known methods for an unknown one.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;

testing::RunResult compare(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {"/usr/bin/timeout", "120", testing::zoomwarp_binary(), "compare"};
  argv.insert(argv.end(), args.begin(), args.end());
  return testing::run_command(argv);
}

const std::string kBoats = testing::samples_dir() + "/boats_lake_sunset.jpg";

TEST(CompareCommand, WritesTheSheetAndTheTablesForEveryMethodAndZoom) {
  testing::TempDir dir;
  const std::string out = dir.path() + "/out";
  const auto r = compare({kBoats, "--methods", "all", "--size", "120x160", "--zoom", "0,0.5,1", "-o", out});
  ASSERT_EQ(r.exit_code, 0) << r.output;

  const json report = json::parse(testing::read_file(out + "/metrics.json"));
  std::set<std::string> names;
  for (const auto& m : report["methods"]) names.insert(m["name"].get<std::string>());
  for (const char* m : {"icaz", "traditional", "retarget-zoom"}) EXPECT_TRUE(names.count(m)) << m;
  const std::size_t methods = report["methods"].size();
  // A row per method and fit (auto and warp by default, issue 41), and the smart crop's, × zoom.
  const std::size_t rows = methods * 2 + 1;
  ASSERT_EQ(report["rows"].size(), rows * 3) << "a row per method × fit, and the smart crop, × zoom";
  std::set<std::string> fits;
  for (const auto& row : report["rows"]) {
    const std::string method = row["method"];
    fits.insert(row["fit"].get<std::string>());
    // The squash measures under both maps, on every cell; a crop (the smart crop) shows shapes as
    // they are, and at zoom 0 neither it nor fit=auto shows all of a 1.6:1 picture on 3:4.
    EXPECT_TRUE(row["independent_coverage"].is_number() && row["salient_coverage"].is_number()) << method;
    if (method == "smart crop") {
      EXPECT_NEAR(row["independent_p99"].get<double>(), 1, 1e-6);
      if (row["zoom"] == 0) EXPECT_LT(row["independent_coverage"].get<double>(), 1);
    }
    if (row["fit"] == "warp" && row["zoom"] == 0 && method != "seam") EXPECT_DOUBLE_EQ(row["independent_coverage"].get<double>(), 1) << method;
    if (method == "icaz" || method == "retarget-zoom") {
      EXPECT_EQ(row["folds"], 0) << method;
      EXPECT_GE(row["coverage"].get<double>(), 0.999) << method;
      // Rotation and line bend on every mesh view; the boats' detected lines are measured.
      EXPECT_GE(row["rotation_p95"].get<double>(), 0) << method;
      EXPECT_GE(row["rotation_spread"].get<double>(), 0) << method;
      EXPECT_GE(row["lines_measured"].get<int>(), 0) << method;
    }
    if (method == "traditional") {
      EXPECT_NEAR(row["rotation_spread"].get<double>(), 0, 1e-9) << "a uniform scale turns nothing";
    }
    if (method == "seam") {
      EXPECT_TRUE(row["rotation_p95"].is_null() && row["lines_measured"].is_null()) << "no mesh";
    }
    if (method == "traditional") {
      EXPECT_DOUBLE_EQ(row["scale_gain"].get<double>(), 1);
    }
  }

  EXPECT_EQ(fits, (std::set<std::string>{"auto", "warp", "crop"}));

  // Cells of 120 × 160 with 8 px gaps and a 48 px label: 3 zoom columns, a row per method and fit.
  const tiles::Raster sheet = testing::decode_image(testing::read_file(out + "/sheet.png"));
  EXPECT_EQ(sheet.width, 8 + 3 * (120 + 8));
  EXPECT_EQ(sheet.height, int(8 + rows * (160 + 48 + 8)));

  const std::string md = testing::read_file(out + "/metrics.md");
  EXPECT_NE(md.find("| retarget-zoom | auto | 0.50 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| smart crop | crop | 0.00 |"), std::string::npos) << md;

  // The same image from a store gives the same sheet, pixel for pixel.
  const std::string store = dir.path() + "/store";
  ASSERT_EQ(testing::run_command({testing::zoomwarp_binary(), "ingest", kBoats, "--store", store, "--id", "boats", "--quiet"}).exit_code, 0);
  const auto again = compare({"--store", store, "--image", "boats", "--methods", "all", "--size", "120x160", "--zoom", "0,0.5,1",
                              "-o", dir.path() + "/again"});
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(testing::read_file(dir.path() + "/again/sheet.png"), testing::read_file(out + "/sheet.png"));
}

TEST(CompareCommand, BadArgumentsExitWithTwoAndSayWhy) {
  testing::TempDir dir;
  const std::string out = dir.path() + "/out";
  auto r = compare({kBoats, "--methods", "icaz,nosuch", "-o", out});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("unknown method 'nosuch'; known: icaz, traditional, retarget-zoom"), std::string::npos) << r.output;
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{kBoats, "--size", "0x640", "-o", out}, {kBoats, "--size", "360", "-o", out},
        {kBoats, "--size", "5000x5000", "-o", out}, {kBoats, "--zoom", "0,2", "-o", out}, {kBoats, "--zoom", "x", "-o", out},
        {kBoats, "--saliency", "itti", "-o", out}, {kBoats}, {"-o", out}, {dir.path() + "/missing.jpg", "-o", out},
        {kBoats, "--methods", "icaz,icaz", "-o", out}, {kBoats, "--fits", "auto,squash", "-o", out},
        {kBoats, "--fits", "warp,warp", "-o", out}, {kBoats, "--max-distortion", "0.5", "-o", out},
        {kBoats, "--max-distortion", "x", "-o", out}}) {
    r = compare(bad);
    EXPECT_EQ(r.exit_code, 2) << ::testing::PrintToString(bad) << "\n" << r.output;
    EXPECT_NE(r.output.find("zoomwarp compare: "), std::string::npos) << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(out)) << "nothing written";
  r = compare({"--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("--methods"), std::string::npos);
}

}  // namespace
}  // namespace zoomwarp
