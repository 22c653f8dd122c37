// method=patch's costs (warp/methods/patch/) at [Lin13 §IV]'s size, 1024×768: the precomputation
// — segmentation (Felzenszwalb–Huttenlocher, then the merging), and the whole model (segmentation,
// significance, grid, the energy factored and solved twice) — and the work of one request: the
// axpy W'·V_W + H'·V_H with the fold check (PatchRetargeting::warped), and the whole view at zoom
// 0.5 (that plus traditional zoom), for 1024×768 → 512×768 and → 665×1182 (what the server
// solves for a 360×640 screen). [Lin13] reports 0.063 s per resize after 10.07 s of
// preprocessing (0.06 s segmentation, 10.01 s context-aware saliency) on a 3.4 GHz CPU; the
// issue's goals are ≤ 1 ms per request and ≤ 2 s of precompute.
//
//   build/bin/patch_bench --benchmark_min_time=0.2   (~20 s; corpus: $ZOOMWARP_CORPUS, default
//                                                    ../shared/corpus; without it the
//                                                    benchmark says so and measures nothing)
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "tests/support/analysed_image.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/methods/patch/patch_precompute.h"
#include "warp/methods/patch/patch_retargeter.h"
#include "warp/methods/patch/patch_segmentation.h"

namespace {

using namespace zoomwarp;

struct Prepared {
  testing::AnalysedImage image;
  warp::SignificanceMap map;
  warp::PatchModel model;
};

void BM_SegmentGraph(benchmark::State& state, const Prepared* p) {
  for (auto _ : state) benchmark::DoNotOptimize(warp::segment_graph(p->image.analysis));
}

void BM_Merge(benchmark::State& state, const Prepared* p) {
  const warp::Patches graph = warp::segment_graph(p->image.analysis);
  warp::Patches merged;
  for (auto _ : state) merged = warp::merge_patches(graph);
  state.counters["components"] = graph.count;
  state.counters["patches"] = merged.count;
}

void BM_BuildModel(benchmark::State& state, const Prepared* p) {
  for (auto _ : state)
    benchmark::DoNotOptimize(warp::build_patch_model(p->image.input(warp::Saliency::kDefault, p->map)));
  state.counters["quads"] = p->model.grid.nx * p->model.grid.ny;
}

void BM_Warped(benchmark::State& state, const Prepared* p, double tw, double th) {
  const warp::PatchRetargeting r(p->image.model.width, p->image.model.height, p->model);
  double blend = 0;
  for (auto _ : state) benchmark::DoNotOptimize(r.warped(tw, th, &blend));
  state.counters["blend"] = blend;
}

void BM_View(benchmark::State& state, const Prepared* p, int sw, int sh) {
  warp::PatchRetargeting r(p->image.model.width, p->image.model.height, p->model);
  warp::ViewRequest request;
  request.zoom = 0.5;
  request.cx = p->image.model.width / 2;
  request.cy = p->image.model.height / 2;
  request.screen_width = sw;
  request.screen_height = sh;
  for (auto _ : state) benchmark::DoNotOptimize(r.view(request));
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  const char* env = std::getenv("ZOOMWARP_CORPUS");
  const std::string path =
      std::string(env ? env : testing::samples_dir() + "/../../shared/corpus") + "/lake_hill_reflection.jpg";
  if (!std::filesystem::exists(path)) {
    std::printf("patch_bench: %s not found (set ZOOMWARP_CORPUS to the corpus folder): nothing measured\n", path.c_str());
    return 0;
  }
  static Prepared p{testing::analyse_image(testing::resize(testing::load_image(path), 1024, 768)), {}, {}};
  p.map = p.image.saliency(warp::Saliency::kDefault);
  p.model = warp::build_patch_model(p.image.input(warp::Saliency::kDefault, p.map));
  benchmark::RegisterBenchmark("Precompute/1024x768/segment_graph", BM_SegmentGraph, &p)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("Precompute/1024x768/merge_patches", BM_Merge, &p)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("Precompute/1024x768/build_patch_model", BM_BuildModel, &p)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("Request/1024x768/warped/512x768", BM_Warped, &p, 512.0, 768.0)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("Request/1024x768/warped/665x1182", BM_Warped, &p, 665.0, 1182.0)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("Request/1024x768/view/360x640", BM_View, &p, 360, 640)->Unit(benchmark::kMicrosecond);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
