// What /mesh costs beyond the warp engine: the body of a view written by api::mesh_json (text
// straight into the body) against the nlohmann tree it replaced (tests/support/mesh_json_reference.h),
// next to the engine's own time for the same views — so the ratio (engine + body) / engine that
// issue 16 bounds (≤ 1.3) can be read off one run.
//
//   build/bin/mesh_json_bench [IMAGE]   (default: ../shared/corpus/nuthatch_tree_trunk.jpg, 20 MP)
//
// The views are those tests/bench/mesh_views.lua sends to a server under wrk: 480×360, zoom
// cycling through 0.2, 0.4, 0.6, 0.8, 1, the centre panning across the image (compute(i) below
// and the script make the same i-th view). The image is ingested into a temporary store and its
// engine made as the server makes it (api::WarpEngines); "Engine" counts what /mesh asks of it,
// the query parsed and the engine looked up included. Read the CPU column.
#include <benchmark/benchmark.h>

#include <filesystem>
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

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::string image = argc > 1 ? argv[1] : testing::samples_dir() + "/../../shared/corpus/nuthatch_tree_trunk.jpg";
  if (!std::filesystem::exists(image)) image = testing::samples_dir() + "/boats_lake_sunset.jpg";
  subject = std::make_unique<testing::IngestedImage>(image, "subject");
  compute(0, false);  // builds the engine (the image model), which no benchmark should time
  benchmark::RegisterBenchmark("Engine", BM_Engine)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("MeshJson/tree", BM_MeshJsonTree)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("MeshJson/text", BM_MeshJsonText)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
