// method=polyfem's costs (warp/methods/polyfem/) beside [PolyFEM §5.4]: 640×480 to 50 % width
// with 200 elements in 0.417 s in all, saliency more than half of it (Core i5-8300; 50–200
// elements, 450–2000 DOFs). The goal: ≤ 2 ms per request after the precompute, on one
// core, the precompute's time reported. Two sources, each a corpus photograph:
//
//   640x480    lake_hill_reflection.jpg resized to the paper's size (its own analysis image);
//   1024x576   nuthatch_tree_trunk.jpg (6028×3391) at the server's analysis size, long side 1024.
//
// For each:
//   Precompute/…/saliency/<kind>, …/pipeline/<kind>   the map of each kind, and the whole
//              precompute from the analysis pixels (that map, then build_polyfem_model);
//   Precompute/…/build_polyfem_model/<kind>           the model alone (counters: cells, nodes,
//              dofs = 2·nodes, the fold-free aspect range), and its parts on the default map:
//              build_cvt_mesh, solve_polyfem, polyfem_fold_free_range;
//   Load/…/parse, Load/…/construct   parse_polyfem_model of the stored bytes, and
//              PolyfemRetargeting made from the model (levels 0–3 sampled; counter: memory_MB);
//   Request/…/target/<50 % width>/first|cached   the paper's target, not of the image's area, so
//              checked at the fallback's levels: the first call (a fresh retargeter each time)
//              and one from the target cache; counters say whether the fallback ran;
//   Request/…/view/<screen>/first|z<zoom>   a whole view() on 360×640 and 640×360: the first of
//              a fresh retargeter at z = 0, then z = 0, 0.5, 1 with the target cached (counters:
//              level, triangles, visible_cells, chord_error_px, budget_limited, fallback).
// Requests and loads use the default saliency. A last line sums it up beside the paper's 0.417 s.
//
//   taskset -c 1 build/bin/polyfem_bench --benchmark_min_time=0.2   (~30 s; corpus:
//       $ZOOMWARP_CORPUS, default ../shared/corpus; without it the benchmark says so and
//       measures nothing)
#include <benchmark/benchmark.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include "tests/support/analysed_image.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/meshing/cvt_mesh.h"
#include "warp/methods/polyfem/polyfem_retargeter.h"

namespace {

using namespace zoomwarp;

struct Source {
  const char* file;  // in the corpus
  int width = 0, height = 0;  // resized to; 0: the whole image, analysed at ≤ 1024 px
};

const Source kSources[] = {
    {"lake_hill_reflection.jpg", 640, 480},
    {"nuthatch_tree_trunk.jpg"},
};

struct Screen {
  int width, height;
};
const Screen kScreens[] = {{360, 640}, {640, 360}};
const double kZooms[] = {0, 0.5, 1};

std::string corpus_dir() {
  const char* dir = std::getenv("ZOOMWARP_CORPUS");
  return dir ? dir : testing::samples_dir() + "/../../shared/corpus";
}

std::string size_name(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

// One source analysed, its maps of both kinds, and the default map's model and bytes.
struct Prepared {
  testing::AnalysedImage image;
  std::array<warp::SignificanceMap, warp::kSaliencies.size()> maps;  // indexed by warp::Saliency
  warp::PolyfemModel model;
  std::string bytes;

  double width() const { return image.model.width; }
  double height() const { return image.model.height; }
  const warp::SignificanceMap& map(warp::Saliency kind) const { return maps[int(kind)]; }
  warp::ScalarMap scalar_map() const {
    const warp::SignificanceMap& s = map(warp::Saliency::kDefault);
    return {s.width, s.height, double(image.analysis.width), double(image.analysis.height), s.values};
  }
};

void BM_Saliency(benchmark::State& state, const Prepared* p, warp::Saliency kind) {
  for (auto _ : state) benchmark::DoNotOptimize(p->image.saliency(kind));
}

// The precompute from pixels: what ingest spends on polyfem's file when the map is its own.
void BM_Pipeline(benchmark::State& state, const Prepared* p, warp::Saliency kind) {
  for (auto _ : state) {
    const warp::SignificanceMap map = p->image.saliency(kind);
    benchmark::DoNotOptimize(warp::build_polyfem_model(p->image.input(kind, map)));
  }
}

void BM_BuildModel(benchmark::State& state, const Prepared* p, warp::Saliency kind) {
  warp::PolyfemModel model;
  for (auto _ : state) model = warp::build_polyfem_model(p->image.input(kind, p->map(kind)));
  state.counters["cells"] = double(model.mesh.cells.size());
  state.counters["nodes"] = double(model.solution.nodes.positions.size());
  state.counters["dofs"] = 2.0 * double(model.solution.nodes.positions.size());
  state.counters["fold_free_low"] = model.fold_free.low;
  state.counters["fold_free_high"] = model.fold_free.high;
}

void BM_CvtMesh(benchmark::State& state, const Prepared* p) {
  const warp::SignificanceMap& s = p->map(warp::Saliency::kDefault);
  for (auto _ : state)
    benchmark::DoNotOptimize(
        warp::build_cvt_mesh(s.values, s.width, s.height, p->image.analysis.width, p->image.analysis.height));
}

void BM_Solve(benchmark::State& state, const Prepared* p) {
  const warp::ScalarMap map = p->scalar_map();
  for (auto _ : state) benchmark::DoNotOptimize(warp::solve_polyfem(p->model.mesh, map));
}

void BM_FoldFreeRange(benchmark::State& state, const Prepared* p) {
  for (auto _ : state) benchmark::DoNotOptimize(warp::polyfem_fold_free_range(p->model.mesh, p->model.solution));
}

void BM_Parse(benchmark::State& state, const Prepared* p) {
  for (auto _ : state) benchmark::DoNotOptimize(warp::parse_polyfem_model(p->bytes));
  state.counters["bytes"] = double(p->bytes.size());
}

void BM_Construct(benchmark::State& state, const Prepared* p) {
  std::size_t memory = 0;
  for (auto _ : state) {
    state.PauseTiming();
    warp::PolyfemModel copy = p->model;
    state.ResumeTiming();
    auto r = std::make_unique<warp::PolyfemRetargeting>(p->width(), p->height(), std::move(copy));
    state.PauseTiming();
    memory = r->memory_bytes();
    r.reset();
    state.ResumeTiming();
  }
  state.counters["memory_MB"] = double(memory) / (1 << 20);
}

// Calls `request(r)` on a retargeter made outside the timing for each iteration: a first request.
// Making one takes ~30 ms, so these benchmarks run a fixed number of iterations, not min_time.
constexpr int kFreshRetargeters = 10;
template <typename Request>
void on_fresh_retargeters(benchmark::State& state, const Prepared* p, Request request) {
  for (auto _ : state) {
    state.PauseTiming();
    auto r = std::make_unique<warp::PolyfemRetargeting>(p->width(), p->height(), p->model);
    state.ResumeTiming();
    request(*r);
    state.PauseTiming();
    r.reset();
    state.ResumeTiming();
  }
}

void report_target(benchmark::State& state, const warp::PolyfemRetargeting::Target& t) {
  state.counters["fallback"] = t.fallback;
  state.counters["lbfgs_iterations"] = t.stats.iterations;
  state.counters["rollbacks"] = t.stats.rollbacks;
  state.counters["converged"] = t.stats.converged;
}

void BM_TargetFirst(benchmark::State& state, const Prepared* p, double tw, double th) {
  std::shared_ptr<const warp::PolyfemRetargeting::Target> t;
  on_fresh_retargeters(state, p, [&](warp::PolyfemRetargeting& r) { t = r.target(tw, th); });
  report_target(state, *t);
}

void BM_TargetCached(benchmark::State& state, const Prepared* p, double tw, double th) {
  warp::PolyfemRetargeting r(p->width(), p->height(), p->model);
  std::shared_ptr<const warp::PolyfemRetargeting::Target> t = r.target(tw, th);
  for (auto _ : state) t = r.target(tw, th);
  report_target(state, *t);
}

warp::ViewRequest view_request(const Prepared* p, Screen screen, double zoom) {
  warp::ViewRequest request;
  request.zoom = zoom;
  request.cx = p->width() / 2;
  request.cy = p->height() / 2;
  request.screen_width = screen.width;
  request.screen_height = screen.height;
  return request;
}

void report_view(benchmark::State& state, const warp::PolyfemViewStats& s) {
  state.counters["level"] = s.level;
  state.counters["triangles"] = double(s.triangles);
  state.counters["visible_cells"] = s.visible_cells;
  state.counters["chord_error_px"] = s.chord_error_px;
  state.counters["budget_limited"] = s.budget_limited;
  state.counters["fallback"] = s.fallback;
}

void BM_ViewFirst(benchmark::State& state, const Prepared* p, Screen screen) {
  const warp::ViewRequest request = view_request(p, screen, 0);
  warp::PolyfemViewStats stats;
  on_fresh_retargeters(state, p, [&](warp::PolyfemRetargeting& r) { benchmark::DoNotOptimize(r.view(request, &stats)); });
  report_view(state, stats);
}

void BM_View(benchmark::State& state, const Prepared* p, Screen screen, double zoom) {
  warp::PolyfemRetargeting r(p->width(), p->height(), p->model);
  const warp::ViewRequest request = view_request(p, screen, zoom);
  warp::PolyfemViewStats stats;
  r.view(request);  // the target cached, as for every request after the first
  for (auto _ : state) benchmark::DoNotOptimize(r.view(request, &stats));
  report_view(state, stats);
}

// What the benchmarks read, kept until the program ends (a deque keeps references on push_back).
std::deque<Prepared>& prepared() {
  static std::deque<Prepared> all;
  return all;
}

Prepared& prepare(const Source& source, const std::string& path) {
  tiles::Raster image = testing::load_image(path);
  if (source.width > 0) image = testing::resize(image, source.width, source.height);
  Prepared& p = prepared().emplace_back();
  p.image = testing::analyse_image(image);
  for (warp::Saliency kind : warp::kSaliencies) p.maps[int(kind)] = p.image.saliency(kind);
  p.model = warp::build_polyfem_model(p.image.input(warp::Saliency::kDefault, p.map(warp::Saliency::kDefault)));
  p.bytes = warp::polyfem_model_bytes(p.model);
  return p;
}

// The size in a benchmark's name: the analysis image's (the image's own when it is ≤ 1024 px).
void register_benchmarks(const Prepared* p) {
  const std::string size = size_name(p->image.analysis.width, p->image.analysis.height);
  const auto add = [](const std::string& name, auto&&... args) {
    return benchmark::RegisterBenchmark(name.c_str(), args...);
  };
  for (warp::Saliency kind : warp::kSaliencies) {
    const std::string kind_name(warp::saliency_name(kind));
    add("Precompute/" + size + "/saliency/" + kind_name, BM_Saliency, p, kind)->Unit(benchmark::kMillisecond);
    add("Precompute/" + size + "/pipeline/" + kind_name, BM_Pipeline, p, kind)->Unit(benchmark::kMillisecond);
    add("Precompute/" + size + "/build_polyfem_model/" + kind_name, BM_BuildModel, p, kind)
        ->Unit(benchmark::kMillisecond);
  }
  add("Precompute/" + size + "/build_cvt_mesh", BM_CvtMesh, p)->Unit(benchmark::kMillisecond);
  add("Precompute/" + size + "/solve_polyfem", BM_Solve, p)->Unit(benchmark::kMillisecond);
  add("Precompute/" + size + "/fold_free_range", BM_FoldFreeRange, p)->Unit(benchmark::kMillisecond);
  add("Load/" + size + "/parse", BM_Parse, p)->Unit(benchmark::kMillisecond);
  add("Load/" + size + "/construct", BM_Construct, p)->Unit(benchmark::kMillisecond);
  // [PolyFEM §5.4]'s target: half the width, the height kept.
  const double tw = p->width() / 2, th = p->height();
  const std::string target = "Request/" + size + "/target/" + size_name(int(tw), int(th));
  add(target + "/first", BM_TargetFirst, p, tw, th)->Unit(benchmark::kMillisecond)->Iterations(kFreshRetargeters);
  add(target + "/cached", BM_TargetCached, p, tw, th)->Unit(benchmark::kMicrosecond);
  for (Screen screen : kScreens) {
    const std::string view = "Request/" + size + "/view/" + size_name(screen.width, screen.height);
    add(view + "/first", BM_ViewFirst, p, screen)->Unit(benchmark::kMillisecond)->Iterations(kFreshRetargeters);
    for (double zoom : kZooms) {
      char z[16];
      std::snprintf(z, sizeof z, "/z%g", zoom);
      add(view + z, BM_View, p, screen, zoom)->Unit(benchmark::kMillisecond);
    }
  }
}

// The console's report (in colour on a terminal), with each run kept for the summary under its
// registered name.
class KeepingReporter : public benchmark::ConsoleReporter {
 public:
  KeepingReporter() : ConsoleReporter(isatty(fileno(stdout)) ? OO_ColorTabular : OO_Tabular) {}
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs)
      if (run.run_type == Run::RT_Iteration) runs_[run.run_name.function_name] = run;
    ConsoleReporter::ReportRuns(runs);
  }
  // CPU seconds per iteration of `name`, or a negative number when it did not run.
  double seconds(const std::string& name) const {
    const auto it = runs_.find(name);
    if (it == runs_.end() || it->second.error_occurred) return -1;
    return it->second.GetAdjustedCPUTime() / benchmark::GetTimeUnitMultiplier(it->second.time_unit);
  }
  double counter(const std::string& name, const std::string& counter) const {
    const auto it = runs_.find(name);
    return it == runs_.end() || !it->second.counters.count(counter) ? -1 : double(it->second.counters.at(counter));
  }

 private:
  std::map<std::string, Run> runs_;
};

// One line for the paper's size: what the paper measured beside ours (CPU time; what did not run
// is left out, e.g. under --benchmark_filter).
void print_summary(const KeepingReporter& r) {
  const std::string pre = "Precompute/640x480/", req = "Request/640x480/";
  const double pipeline = r.seconds(pre + "pipeline/default"), saliency = r.seconds(pre + "saliency/default");
  const double first = r.seconds(req + "target/320x480/first"), cached = r.seconds(req + "target/320x480/cached");
  const double view = r.seconds(req + "view/360x640/z0.5"), load = r.seconds("Load/640x480/construct");
  const double cells = r.counter(pre + "build_polyfem_model/default", "cells");
  const double dofs = r.counter(pre + "build_polyfem_model/default", "dofs");
  const double fallback = r.counter(req + "target/320x480/first", "fallback");
  std::printf("polyfem_bench summary, 640x480 -> 320x480 (CPU):");
  if (pipeline >= 0)
    std::printf(" precompute from pixels %.3f s (saliency %.3f s; %.0f cells, %.0f DOFs) beside [PolyFEM §5.4]'s 0.417 s;",
                pipeline, saliency, cells, dofs);
  if (first >= 0) {
    const double iterations = r.counter(req + "target/320x480/first", "lbfgs_iterations");
    std::printf(" the target %.2f ms at first (", first * 1e3);
    fallback > 0 ? std::printf("the fallback, %.0f L-BFGS steps", iterations) : std::printf("the axpy");
    std::printf("), %.3f us cached;", cached * 1e6);
  }
  if (view >= 0) std::printf(" a 360x640 view at zoom 0.5 %.3f ms (goal <= 2 ms);", view * 1e3);
  if (load >= 0) std::printf(" load %.1f ms", load * 1e3);
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  const std::string corpus = corpus_dir();
  int registered = 0;
  for (const Source& source : kSources) {
    const std::string path = corpus + "/" + source.file;
    if (!std::filesystem::exists(path)) {
      std::printf("polyfem_bench: %s not found (set ZOOMWARP_CORPUS to the corpus folder): it is skipped\n",
                  path.c_str());
      continue;
    }
    register_benchmarks(&prepare(source, path));
    ++registered;
  }
  if (registered == 0) return 0;
  KeepingReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  print_summary(reporter);
  return 0;
}
