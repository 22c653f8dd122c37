// `zoomwarp ingest` with many inputs in one run (issue 28): folders and a list on standard input,
// every bad file named with its reason while the good ones are published, files already
// published from the same bytes skipped (so a run killed part way resumes without publishing
// anything twice), ids taken twice refused, and --jobs 2 publishing what --jobs 1 does.
// Images are small: every ingest also runs the warp analysis.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::TempDir;

void write_bytes(const std::string& path, const std::string& bytes) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

void write_picture(const std::string& path, int w, int h) {
  fs::create_directories(fs::path(path).parent_path());
  testing::write_image(path, testing::test_pattern(w, h, 3));
}

// The version folder `id` is published in (its link's target, ID@VERSION); "" when unpublished.
std::string published_version(const std::string& store, const std::string& id) {
  std::error_code ec;
  const fs::path target = fs::read_symlink(fs::path(store) / "images" / id, ec);
  return ec ? "" : target.filename().string();
}

// Every published id and its version folder.
std::map<std::string, std::string> published(const std::string& store) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::directory_iterator(store + "/images"))
    out[e.path().filename().string()] = published_version(store, e.path().filename().string());
  return out;
}

// How many versions of `id` the store holds (published or superseded).
int versions_of(const std::string& store, const std::string& id) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(store + "/versions"))
    if (e.path().filename().string().starts_with(id + "@")) ++n;
  return n;
}

json manifest_of(const std::string& store, const std::string& id) {
  return json::parse(testing::read_file(store + "/images/" + id + "/manifest.json"));
}

// The refusal line naming `path`, "" when there is none.
std::string refusal_of(const std::string& output, const std::string& path) {
  const std::string head = "zoomwarp ingest: refused " + path + ": ";
  const auto at = output.find(head);
  return at == std::string::npos ? "" : output.substr(at + head.size(), output.find('\n', at) - at - head.size());
}

TEST(BulkIngest, FolderPublishesTheGoodFilesNamesEachBadOneAndSkipsWhatIsUnchanged) {
  TempDir dir;
  const std::string in = dir.path() + "/in", store = dir.path() + "/store";
  write_picture(in + "/a.png", 64, 48);
  write_picture(in + "/b.jpg", 80, 60);
  write_picture(in + "/sub/c.png", 48, 64);
  write_picture(in + "/.hidden.png", 32, 32);         // hidden: left out,
  write_picture(in + "/.cache/d.png", 32, 32);        // and so are hidden folders
  write_bytes(in + "/notes.txt", "not an image");
  write_bytes(in + "/anim.gif", std::string("GIF89a\x01\x00\x01\x00\x80\x00\x00", 13) + std::string(20, '\0'));
  write_bytes(in + "/corrupt.png", std::string("\x89PNG\r\n\x1a\n", 8) + std::string(200, 'x'));
  write_picture(dir.path() + "/whole.jpg", 200, 200);
  const std::string whole = testing::read_file(dir.path() + "/whole.jpg");
  write_bytes(in + "/truncated.jpg", whole.substr(0, whole.size() / 2));
  write_picture(in + "/big.png", 300, 300);  // over --max-pixels
  const std::vector<std::string> ingest = {testing::zoomwarp_binary(), "ingest", in, "--store", store,
                                           "--max-pixels", "50000"};

  const auto first = testing::run_command(ingest);
  EXPECT_EQ(first.exit_code, 6) << first.output;
  EXPECT_NE(first.output.find("8 images: 3 added, 0 skipped (unchanged), 5 refused"), std::string::npos) << first.output;
  EXPECT_NE(first.output.find("ingested a: 64x48"), std::string::npos) << first.output;
  EXPECT_EQ(first.output.find('\r'), std::string::npos) << "no progress line without a terminal";
  EXPECT_NE(refusal_of(first.output, in + "/notes.txt").find("unsupported image format"), std::string::npos) << first.output;
  EXPECT_NE(refusal_of(first.output, in + "/anim.gif").find("unsupported image format"), std::string::npos) << first.output;
  EXPECT_NE(refusal_of(first.output, in + "/corrupt.png").find("cannot decode image"), std::string::npos) << first.output;
  EXPECT_NE(refusal_of(first.output, in + "/truncated.jpg").find("corrupt or truncated"), std::string::npos) << first.output;
  EXPECT_NE(refusal_of(first.output, in + "/big.png").find("over the limit"), std::string::npos) << first.output;
  // The summary lists each refusal again, in path order.
  const auto summary = first.output.find("8 images:");
  EXPECT_NE(first.output.find("  " + in + "/anim.gif: unsupported", summary), std::string::npos) << first.output;
  EXPECT_LT(first.output.find("  " + in + "/anim.gif:", summary), first.output.find("  " + in + "/truncated.jpg:", summary));

  const auto versions = published(store);
  EXPECT_EQ(versions.size(), 3u);
  for (const char* id : {"a", "b", "c"}) EXPECT_FALSE(versions.at(id).empty()) << id;
  EXPECT_EQ(manifest_of(store, "c")["width"], 48);
  const auto sha = testing::run_command({"/usr/bin/sha256sum", in + "/a.png"});
  ASSERT_EQ(sha.exit_code, 0);
  EXPECT_EQ(manifest_of(store, "a")["source"]["sha256"], sha.output.substr(0, 64));

  // Again: nothing changed, nothing published.
  const auto again = testing::run_command(ingest);
  EXPECT_EQ(again.exit_code, 6) << again.output;
  EXPECT_NE(again.output.find("8 images: 0 added, 3 skipped (unchanged), 5 refused"), std::string::npos) << again.output;
  EXPECT_NE(again.output.find("skipped a: " + in + "/a.png unchanged, version " + versions.at("a").substr(2) + " kept"),
            std::string::npos)
      << again.output;
  EXPECT_EQ(published(store), versions);
  for (const char* id : {"a", "b", "c"}) EXPECT_EQ(versions_of(store, id), 1) << id;

  // New bytes under an id replace it; --force ingests the same bytes again.
  write_picture(in + "/b.jpg", 60, 80);
  const auto changed = testing::run_command(ingest);
  EXPECT_NE(changed.output.find("8 images: 1 added, 2 skipped (unchanged), 5 refused"), std::string::npos) << changed.output;
  EXPECT_NE(published_version(store, "b"), versions.at("b"));
  EXPECT_EQ(manifest_of(store, "b")["width"], 60);
  EXPECT_EQ(published_version(store, "a"), versions.at("a"));
  const auto forced = testing::run_command({testing::zoomwarp_binary(), "ingest", in + "/a.png", "--store", store, "--force"});
  EXPECT_EQ(forced.exit_code, 0) << forced.output;
  EXPECT_NE(forced.output.find("ingested a: "), std::string::npos) << forced.output;
  EXPECT_NE(published_version(store, "a"), versions.at("a"));
  // A single file keeps its own exit code and prints no summary.
  const auto single = testing::run_command({testing::zoomwarp_binary(), "ingest", in + "/sub/c.png", "--store", store});
  EXPECT_EQ(single.exit_code, 0) << single.output;
  EXPECT_NE(single.output.find("skipped c: "), std::string::npos) << single.output;
  EXPECT_EQ(single.output.find("images:"), std::string::npos) << single.output;
}

TEST(BulkIngest, StandardInputListAndAnIdTakenTwice) {
  TempDir dir;
  const std::string store = dir.path() + "/store", list = dir.path() + "/list";
  write_picture(dir.path() + "/x/one.png", 64, 48);
  write_picture(dir.path() + "/y/one.jpg", 80, 60);  // the same id as x/one.png
  write_picture(dir.path() + "/two.png", 40, 30);
  write_bytes(list, dir.path() + "/x/one.png\n\n" + dir.path() + "/y/one.jpg\r\n" + dir.path() + "/two.png\n" +
                        dir.path() + "/missing.png\n");
  const auto r = testing::run_command(
      {"/bin/sh", "-c", "exec \"$0\" ingest - --store \"$1\" --quiet < \"$2\"", testing::zoomwarp_binary(), store, list});
  EXPECT_EQ(r.exit_code, 6) << r.output;
  std::vector<std::string> ids;  // --quiet: the ids published, one per line; refusals and logs aside
  std::istringstream lines(r.output);
  for (std::string line; std::getline(lines, line);)
    if (!line.starts_with("zoomwarp ingest: ") && !line.starts_with("{")) ids.push_back(line);
  EXPECT_EQ(ids, (std::vector<std::string>{"one", "two"})) << r.output;
  EXPECT_EQ(refusal_of(r.output, dir.path() + "/y/one.jpg"),
            "id one already taken by " + dir.path() + "/x/one.png in this run") << r.output;
  EXPECT_EQ(refusal_of(r.output, dir.path() + "/missing.png"), "no such file") << r.output;
  EXPECT_EQ(r.output.find("images:"), std::string::npos) << "--quiet: no summary\n" << r.output;
  EXPECT_EQ(manifest_of(store, "one")["width"], 64) << "the first file keeps the id";
  EXPECT_EQ(published(store).size(), 2u);
}

TEST(BulkIngest, IdNamesASingleFileOnly) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  write_picture(dir.path() + "/in/a.png", 32, 32);
  write_picture(dir.path() + "/in/b.png", 32, 32);
  for (const std::vector<std::string>& inputs :
       {std::vector<std::string>{dir.path() + "/in/a.png", dir.path() + "/in/b.png"}, {dir.path() + "/in"}, {"-"}}) {
    std::vector<std::string> argv = {testing::zoomwarp_binary(), "ingest", "--store", store, "--id", "x"};
    argv.insert(argv.end(), inputs.begin(), inputs.end());
    const auto r = testing::run_command(argv);
    EXPECT_EQ(r.exit_code, 2) << inputs[0];
    EXPECT_NE(r.output.find("--id names one image"), std::string::npos) << r.output;
  }
  EXPECT_FALSE(fs::exists(store)) << "a usage error makes no store";
}

// SIGKILLed right after its first image was published, then run again: the rest is published,
// and nothing twice — the first run's image keeps its version.
TEST(BulkIngest, KilledRunResumesWithoutPublishingAnythingTwice) {
  TempDir dir;
  const std::string store = dir.path() + "/store";
  write_picture(dir.path() + "/first.png", 64, 48);
  write_picture(dir.path() + "/later1.jpg", 2400, 1800);  // seconds, to be killed in
  write_picture(dir.path() + "/later2.jpg", 2400, 1800);
  const std::vector<std::string> ingest = {testing::zoomwarp_binary(), "ingest", dir.path() + "/first.png",
                                           dir.path() + "/later1.jpg", dir.path() + "/later2.jpg", "--store", store};

  const pid_t pid = testing::spawn_quietly(ingest);
  ASSERT_GT(pid, 0);
  bool exited = false;
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline && published_version(store, "first").empty()) {
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (!exited) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
  }
  ASSERT_FALSE(exited) << "the run ended (status " << status << ") before it could be killed";
  const auto before = published(store);
  ASSERT_EQ(before.count("first"), 1u) << "nothing was published within 60 s";
  ASSERT_EQ(before.count("later2"), 0u) << "the run was killed too late to show a resume";

  const auto resumed = testing::run_command(ingest);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  const std::size_t skipped = before.size(), added = 3 - before.size();
  EXPECT_NE(resumed.output.find("3 images: " + std::to_string(added) + " added, " + std::to_string(skipped) +
                                " skipped (unchanged), 0 refused"),
            std::string::npos)
      << resumed.output;
  const auto after = published(store);
  EXPECT_EQ(after.size(), 3u);
  for (const auto& [id, version] : before) EXPECT_EQ(after.at(id), version) << id;
  for (const auto& [id, version] : after) EXPECT_EQ(versions_of(store, id), 1) << id;
}

TEST(BulkIngest, TwoJobsPublishWhatOneDoes) {
  TempDir dir;
  const std::string in = dir.path() + "/in";
  write_picture(in + "/p1.png", 64, 48);
  write_picture(in + "/p2.jpg", 120, 40);
  write_picture(in + "/p3.png", 33, 77);
  testing::write_image(in + "/p4.png", testing::test_pattern(50, 50, 4));
  std::map<std::string, std::map<std::string, std::string>> stores;  // jobs -> id -> every file's bytes
  for (const std::string jobs : {"1", "2"}) {
    const std::string store = dir.path() + "/store" + jobs;
    const auto r = testing::run_command({testing::zoomwarp_binary(), "ingest", in, "--store", store, "--jobs", jobs,
                                         "--ingest-threads", "2"});
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("4 images: 4 added, 0 skipped (unchanged), 0 refused"), std::string::npos) << r.output;
    for (const auto& [id, version] : published(store)) {
      const fs::path folder = fs::path(store) / "versions" / version;
      for (const auto& f : fs::directory_iterator(folder)) {
        const std::string name = f.path().filename().string();
        if (name != "manifest.json") stores[jobs][id + "/" + name] = testing::read_file(f.path().string());
      }
      json m = json::parse(testing::read_file((folder / "manifest.json").string()));
      m.erase("version");  // unique per publish
      m.erase("created_ms");
      stores[jobs][id + "/manifest.json"] = m.dump();
    }
  }
  EXPECT_EQ(stores["1"].size(), stores["2"].size());
  for (const auto& [file, bytes] : stores["1"]) {
    ASSERT_EQ(stores["2"].count(file), 1u) << file;
    EXPECT_TRUE(stores["2"].at(file) == bytes) << file << " differs between --jobs 1 and --jobs 2";
  }
}

}  // namespace
}  // namespace zoomwarp
