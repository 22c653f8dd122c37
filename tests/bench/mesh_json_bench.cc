// What /mesh costs beyond the warp engine: the body of a view written by api::mesh_json (text
// straight into the body) against the nlohmann tree it replaced (tests/support/mesh_json_reference.h),
// next to the engine's own time for the same views — so the ratio (engine + body) / engine that
// issue 16 bounds (≤ 1.3) can be read off one run.
//
//   build/bin/mesh_json_bench [IMAGE]                          (ingested into a temporary store)
//   build/bin/mesh_json_bench --store DIR --image ID [--views FILE]
//
// IMAGE defaults to ../shared/corpus/nuthatch_tree_trunk.jpg (20 MP). The views are those
// tests/bench/mesh_views.lua sends to a server under wrk: 480×360, zoom cycling through 0.2, 0.4,
// 0.6, 0.8, 1, the centre panning across the image (compute(i) below and the script make the same
// i-th view). With --views, "Engine/listed" also times the views of a request list — one /mesh
// request target (or query string) per line, cycled — as scripts/bench-peers.sh does with the list
// its server answers, so that the server's CPU per request is compared with the engine's on the
// same views. The engine is made as the server makes it (api::WarpEngines); "Engine" counts what
// /mesh asks of it, the query parsed and the engine looked up included. Read the CPU column.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "api/mesh_json.h"
#include "tests/support/ingested_image.h"
#include "tests/support/mesh_json_reference.h"

namespace {

using namespace zoomwarp;

// The image and its engines, made in main().
std::unique_ptr<testing::IngestedImage> subject;
using Computed = testing::IngestedImage::MeshViews;

// The i-th view of mesh_views.lua, as /mesh computes it: five zoom levels, the centre stepping
// across the image; with `morph`, the geomorph pair from the same centre zoomed out by 0.1.
Computed compute(long i, bool morph) {
  static constexpr const char* kZooms[] = {"0.2", "0.4", "0.6", "0.8", "1"};
  static constexpr const char* kFromZooms[] = {"0.1", "0.3", "0.5", "0.7", "0.9"};
  const tiles::Manifest& m = subject->entry->manifest;
  const long cx = m.width / 10 + i * 97 % (m.width * 8 / 10), cy = m.height / 10 + i * 61 % (m.height * 8 / 10);
  return subject->mesh_views("w=480&h=360&zoom=" + std::string(kZooms[i % 5]) + "&cx=" + std::to_string(cx) +
                             "&cy=" + std::to_string(cy) + (morph ? "&from_zoom=" + std::string(kFromZooms[i % 5]) : ""));
}

// The engine alone: one new view (or pair) per iteration, as the server computes it for /mesh.
void BM_Engine(benchmark::State& state) {
  long i = 0;
  std::size_t vertices = 0;
  for (auto _ : state) vertices += compute(i++, state.range(0) != 0).view.source.vertices.size();
  state.counters["vertices"] = benchmark::Counter(double(vertices), benchmark::Counter::kAvgIterations);
  state.SetLabel(state.range(0) ? "geomorph pairs" : "views");
}

// The query strings of --views, in order.
std::vector<std::string> listed;

// The engine alone on the listed views, cycled: one view (or pair) per iteration.
void BM_EngineListed(benchmark::State& state) {
  std::size_t i = 0, vertices = 0;
  for (auto _ : state) vertices += subject->mesh_views(listed[i++ % listed.size()]).view.source.vertices.size();
  state.counters["vertices"] = benchmark::Counter(double(vertices), benchmark::Counter::kAvgIterations);
  state.SetLabel(std::to_string(listed.size()) + " listed views");
}

// The first views of the sequence, computed once, for the writers.
const std::vector<Computed>& views(bool morph) {
  static std::vector<Computed> plain, pairs;
  std::vector<Computed>& out = morph ? pairs : plain;
  constexpr long kViews = 25;
  for (long i = long(out.size()); i < kViews; ++i) out.push_back(compute(i, morph));
  return out;
}

template <class Writer>
void time_writer(benchmark::State& state, Writer writer) {
  const std::vector<Computed>& all = views(state.range(0) != 0);
  const tiles::Manifest& m = subject->entry->manifest;
  std::size_t i = 0, bytes = 0;
  for (auto _ : state) {
    const Computed& w = all[i++ % all.size()];
    const std::string body = writer(m, w.query, w.view, w.morph ? &*w.morph : nullptr, api::DziLayout{}, std::string("jpg"));
    bytes += body.size();
    benchmark::DoNotOptimize(body.data());
  }
  state.counters["bytes"] = benchmark::Counter(double(bytes), benchmark::Counter::kAvgIterations);
  state.SetLabel(state.range(0) ? "geomorph pairs" : "views");
}

void BM_MeshJsonTree(benchmark::State& state) { time_writer(state, testing::reference_mesh_json); }
void BM_MeshJsonText(benchmark::State& state) { time_writer(state, api::mesh_json); }

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr,
               "mesh_json_bench: %s\n"
               "usage: mesh_json_bench [IMAGE] [--views FILE] [benchmark flags]\n"
               "       mesh_json_bench --store DIR --image ID [--views FILE] [benchmark flags]\n"
               "  IMAGE         a picture to ingest into a temporary store (default: the 20 MP corpus photo)\n"
               "  --store DIR   an existing store, read only, with --image ID the image in it\n"
               "  --views FILE  /mesh request targets or query strings, one per line: adds Engine/listed\n",
               why.c_str());
  std::exit(2);
}

// The query strings of a request list: what follows '?' on each non-empty line (the whole line
// if it has none).
std::vector<std::string> read_views(const std::string& file) {
  std::ifstream in(file);
  if (!in) usage("cannot read " + file);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    const std::size_t q = line.find('?');
    out.push_back(q == std::string::npos ? line : line.substr(q + 1));
  }
  if (out.empty()) usage(file + " lists no views");
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::string image, store_dir, id, views_file;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h") usage("the warp engine's time per /mesh view and the body writers'");
    else if (arg == "--store") store_dir = value();
    else if (arg == "--image") id = value();
    else if (arg == "--views") views_file = value();
    else if (arg.starts_with("-") || !image.empty()) usage("unknown argument " + arg);
    else image = arg;
  }
  if (store_dir.empty() != id.empty()) usage("--store and --image go together");
  if (!store_dir.empty() && !image.empty()) usage("IMAGE or --store, not both");
  if (!views_file.empty()) listed = read_views(views_file);
  if (!store_dir.empty()) {
    subject = std::make_unique<testing::IngestedImage>(testing::IngestedImage::InStore{store_dir}, id);
  } else {
    if (image.empty()) image = testing::samples_dir() + "/../../shared/corpus/nuthatch_tree_trunk.jpg";
    if (!std::filesystem::exists(image)) image = testing::samples_dir() + "/boats_lake_sunset.jpg";
    subject = std::make_unique<testing::IngestedImage>(image, "subject");
  }
  // Builds the engines (the image model), which no benchmark should time.
  if (listed.empty()) compute(0, false);
  else subject->mesh_views(listed.front());
  benchmark::RegisterBenchmark("Engine", BM_Engine)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
  if (!listed.empty()) benchmark::RegisterBenchmark("Engine/listed", BM_EngineListed)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("MeshJson/tree", BM_MeshJsonTree)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("MeshJson/text", BM_MeshJsonText)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
