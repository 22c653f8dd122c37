// method=mp's costs (warp/methods/mp/) at the papers' sizes: the precomputation — ingest's
// analysis that mp shares with the other methods (the saliency map of each kind, line detection)
// and mp's own model (build_mp_model) — and the solve per target, cold and warm from a nearby
// cached target, with its Newton steps and object scale z as counters:
//
//   743×512 → 320×320, 480×270, 320×240   [Guo09 Fig. 9]
//   800×600 → 320×320, 320×240, 512×270   [Kumar (004)]
//   1024×768 → 360×640                    the goal: ≤ 10 ms per request on one core
//            → 665×1182                   what the server solves for a 360×640 screen (the
//                                         image's area at the screen's aspect)
//
// Each source is a corpus photograph resized to that size (it is its own analysis image, long
// side ≤ 1024). The other targets are the papers' own sizes, not the server's equal-area ones.
//
//   build/bin/mp_bench --benchmark_min_time=0.2   (~30 s; corpus: $ZOOMWARP_CORPUS, default
//                                                 ../shared/corpus; without it the benchmark
//                                                 says so and measures nothing)
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/support/analysed_image.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/lines/line_detection.h"
#include "warp/methods/mp/mp_precompute.h"
#include "warp/methods/mp/mp_solve.h"

namespace {

using namespace zoomwarp;

struct Size {
  int w = 0, h = 0;
};

struct Source {
  const char* file;  // in the corpus
  Size size;         // resized to
  std::vector<Size> targets;
};

const Source kSources[] = {
    {"beach_kites_people.jpg", {743, 512}, {{320, 320}, {480, 270}, {320, 240}}},
    {"cincinnati_bridge_night.jpg", {800, 600}, {{320, 320}, {320, 240}, {512, 270}}},
    {"lake_hill_reflection.jpg", {1024, 768}, {{360, 640}, {665, 1182}}},
};

std::string corpus_dir() {
  const char* dir = std::getenv("ZOOMWARP_CORPUS");
  return dir ? dir : testing::samples_dir() + "/../../shared/corpus";
}

std::string size_name(Size s) { return std::to_string(s.w) + "x" + std::to_string(s.h); }

// One source analysed, its map of one kind and its model: what the solves start from.
struct Prepared {
  const testing::AnalysedImage* image = nullptr;
  warp::SignificanceMap map;
  warp::MpModel model;
};

void BM_Saliency(benchmark::State& state, const testing::AnalysedImage* image, warp::Saliency kind) {
  for (auto _ : state) benchmark::DoNotOptimize(image->saliency(kind));
}

void BM_DetectLines(benchmark::State& state, const testing::AnalysedImage* image) {
  for (auto _ : state)
    benchmark::DoNotOptimize(warp::detect_lines(image->analysis, image->model.width, image->model.height));
}

void BM_BuildModel(benchmark::State& state, const Prepared* p, warp::Saliency kind) {
  for (auto _ : state) benchmark::DoNotOptimize(warp::build_mp_model(p->image->input(kind, p->map)));
  state.counters["vertices"] = double(p->model.mesh.vertices.size());
  state.counters["objects"] = double(p->model.objects.size());
  state.counters["lines"] = double(p->model.lines.size());
}

void report(benchmark::State& state, const warp::MpSolution& s) {
  state.counters["newton_steps"] = s.iterations;
  state.counters["z"] = s.object_scale;
  state.counters["rigid"] = s.rigid;
  state.counters["rigidity_px"] = s.rigidity_residual;  // how far from eq. 3 when not rigid
}

void BM_SolveCold(benchmark::State& state, const Prepared* p, Size target) {
  warp::MpSolution s;
  for (auto _ : state) s = warp::mp_solve(p->model, target.w, target.h);
  report(state, s);
}

// The nearby cached target: 2 % wider (a screen a few px wider, or a resized window).
void BM_SolveWarm(benchmark::State& state, const Prepared* p, Size target) {
  warp::MpSolveOptions warm;
  warm.warm_width = target.w * 1.02;
  warm.warm_height = target.h;
  warm.warm_start = warp::mp_solve(p->model, warm.warm_width, warm.warm_height).positions;
  warp::MpSolution s;
  for (auto _ : state) s = warp::mp_solve(p->model, target.w, target.h, warm);
  report(state, s);
  state.counters["warm_started"] = s.warm_started;
}

// What the benchmarks read, kept until the program ends (a deque keeps references on push_back).
std::deque<testing::AnalysedImage>& analysed_images() {
  static std::deque<testing::AnalysedImage> images;
  return images;
}
std::deque<Prepared>& prepared() {
  static std::deque<Prepared> all;
  return all;
}

void register_source(const Source& source, const std::string& path) {
  const std::string size = size_name(source.size);
  const testing::AnalysedImage* image = &analysed_images().emplace_back(
      testing::analyse_image(testing::resize(testing::load_image(path), source.size.w, source.size.h)));
  benchmark::RegisterBenchmark(("Precompute/" + size + "/detect_lines").c_str(), BM_DetectLines, image)
      ->Unit(benchmark::kMillisecond);
  for (warp::Saliency kind : warp::kSaliencies) {
    const std::string kind_name(warp::saliency_name(kind));
    Prepared* p = &prepared().emplace_back(Prepared{image, image->saliency(kind), {}});
    p->model = warp::build_mp_model(image->input(kind, p->map));
    benchmark::RegisterBenchmark(("Precompute/" + size + "/saliency/" + kind_name).c_str(), BM_Saliency, image, kind)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("Precompute/" + size + "/build_mp_model/" + kind_name).c_str(), BM_BuildModel, p, kind)
        ->Unit(benchmark::kMillisecond);
    for (Size target : source.targets) {
      const std::string name = size + "/" + kind_name + "/" + size_name(target);
      benchmark::RegisterBenchmark(("Solve/cold/" + name).c_str(), BM_SolveCold, p, target)
          ->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark(("Solve/warm/" + name).c_str(), BM_SolveWarm, p, target)
          ->Unit(benchmark::kMillisecond);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  const std::string corpus = corpus_dir();
  int registered = 0;
  for (const Source& source : kSources) {
    const std::string path = corpus + "/" + source.file;
    if (!std::filesystem::exists(path)) {
      std::printf("mp_bench: %s not found (set ZOOMWARP_CORPUS to the corpus folder): its sizes are skipped\n",
                  path.c_str());
      continue;
    }
    register_source(source, path);
    ++registered;
  }
  if (registered == 0) return 0;
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
