// Time per zoom and per pan action of the ICAZ operator at 480×360 with 500 px² triangles, along
// the zoom range, on a ≥ 10 MP wide photo and on a ≥ 300 MP synthetic mosaic, and of a geomorph
// between two views; plus the paper's
// Fig. 9 comparison with a uniform mesh of the finest resolution, the Retargeting+Zooming
// baseline on that mesh (method=retarget-zoom: its load, a view at a new screen aspect, a view at
// a cached one), and the model-building cost.
// Then the bounds of warp/core/limits.h: the same views with 0 and with kMaxLines line constraints of
// kMaxTotalLineLength in all (axis-aligned and oblique mixed), and the largest screen (4096×4096)
// on a 4:1 panorama at z = 0.
//
//   build/bin/icaz_bench [IMAGE]   (default: ../shared/corpus/world_satellite_map.jpg, 5400×2500)
//
// A zoom action changes the target size, so its coarse warp is computed (not cached); a pan at a
// fixed zoom reuses it. The operator only ever sees a ≤ 1024 px copy of the image and its size,
// which is why the mosaic needs no 300 MP of pixels here.
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <memory>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/core/limits.h"
#include "warp/icaz/icaz.h"
#include "warp/methods/retarget_zoom/retarget_zoom.h"

namespace {

using namespace zoomwarp;

struct Subject {
  std::string name;
  tiles::Raster reduced;
  double width, height;
  std::unique_ptr<warp::Icaz> icaz;
};

std::vector<Subject>& subjects() {
  static std::vector<Subject> s;
  return s;
}

tiles::Raster reduce(const tiles::Raster& full, int max_side) {
  const double f = std::min(1.0, double(max_side) / std::max(full.width, full.height));
  return testing::resize(full, std::max(1, int(full.width * f)), std::max(1, int(full.height * f)));
}

void BM_BuildModel(benchmark::State& state, int which) {
  Subject& s = subjects()[which];
  for (auto _ : state) benchmark::DoNotOptimize(warp::make_image_model(s.reduced, s.width, s.height));
  state.SetLabel(s.name);
}

// One zoom action per iteration: the zoom level moves by a hair each time (towards the middle of
// the range), over more levels than the coarse-warp cache holds, so the coarse warp is never a
// cache hit.
void BM_Zoom(benchmark::State& state, int which) {
  Subject& s = subjects()[which];
  const double z = state.range(0) / 100.0;
  int i = 0;
  std::size_t vertices = 0;
  double iterations = 0, coarse_iterations = 0, guard_rounds = 0, coarse_computed = 0;
  for (auto _ : state) {
    warp::ViewRequest r;
    const double step = 1e-5 * (i++ % 1000);
    r.zoom = z < 0.5 ? z + step : z - step;
    r.cx = 0.4 * s.width, r.cy = 0.5 * s.height;
    const warp::View v = s.icaz->view(r);
    vertices = v.source.vertices.size();
    iterations += v.fine_stats.iterations, guard_rounds += v.fine_stats.guard_rounds;
    coarse_iterations += v.coarse_stats.iterations, coarse_computed += v.coarse_stats.converged;  // not a cache hit
  }
  state.counters["vertices"] = double(vertices);
  state.counters["fine_iterations"] = benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
  state.counters["coarse_iterations"] = benchmark::Counter(coarse_iterations, benchmark::Counter::kAvgIterations);
  state.counters["coarse_computed"] = benchmark::Counter(coarse_computed, benchmark::Counter::kAvgIterations);
  state.counters["guard_rounds"] = benchmark::Counter(guard_rounds, benchmark::Counter::kAvgIterations);
  state.SetLabel(s.name);
}

// One pan per iteration at a fixed zoom: the view centre moves across the image.
void BM_Pan(benchmark::State& state, int which) {
  Subject& s = subjects()[which];
  const double z = state.range(0) / 100.0;
  int i = 0;
  for (auto _ : state) {
    warp::ViewRequest r;
    r.zoom = z;
    r.cx = s.width * (0.1 + 0.8 * ((i * 37) % 100) / 100.0), r.cy = s.height * (0.2 + 0.6 * ((i * 61) % 100) / 100.0);
    ++i;
    benchmark::DoNotOptimize(s.icaz->view(r));
  }
  state.SetLabel(s.name);
}

// A geomorph between two views [ICAZ §5.3] (the views made once, outside the timing): the
// common refinement of their cuts and both ends' positions, each vertex a view lacks located in
// that view's mesh. Arg 0: z = 0.3 → 0.7 across the image (the test's pair); 1: z = 0 → 1 at
// the centre (the view at z = 0 lacks nearly everything).
void BM_Geomorph(benchmark::State& state, int which) {
  Subject& s = subjects()[which];
  warp::ViewRequest a, b;
  if (state.range(0) == 0) {
    a.zoom = 0.3, a.cx = 0.3 * s.width, a.cy = 0.6 * s.height;
    b.zoom = 0.7, b.cx = 0.7 * s.width, b.cy = 0.4 * s.height;
  } else {
    a.zoom = 0, b.zoom = 1;
    a.cx = b.cx = 0.5 * s.width, a.cy = b.cy = 0.5 * s.height;
  }
  const warp::View va = s.icaz->view(a), vb = s.icaz->view(b);
  std::size_t vertices = 0;
  for (auto _ : state) vertices = s.icaz->geomorph(va, vb).source.vertices.size();
  state.counters["vertices"] = double(vertices);
  state.counters["lacked"] = double(2 * vertices - va.source.vertices.size() - vb.source.vertices.size());
  state.SetLabel(s.name + (state.range(0) == 0 ? ", z 0.3 -> 0.7 across" : ", z 0 -> 1"));
}

// Fig. 9: a uniform mesh whose triangles are as fine as the adaptive mesh's finest (500 px² at
// z = 1), warped whole for a zoom action.
void BM_UniformMeshZoom(benchmark::State& state, int which) {
  Subject& s = subjects()[which];
  warp::CoarseMeshOptions fine;
  fine.max_triangle_area = 500;
  fine.vertex_budget = 1 << 30;
  const auto cm = warp::build_coarse_mesh(s.width, s.height, {}, fine);
  const auto weights = warp::triangle_weights(cm.mesh, s.icaz->model().significance, 0.2);
  const warp::ShapeWarp warp(cm.mesh, weights, s.width, s.height);
  const double z = state.range(0) / 100.0;
  for (auto _ : state) {
    const auto g = warp::zoom_geometry(s.width, s.height, 480, 360, z);
    benchmark::DoNotOptimize(warp.solve(g.target_width, g.target_height));
  }
  state.counters["vertices"] = double(cm.mesh.vertices.size());
  state.SetLabel(s.name);
}

// method=retarget-zoom [ICAZ §6.1]. Arg 0: load (uniform mesh built and factored); 1: the first
// view at a screen aspect (the whole mesh warped; the screen width changes by a pixel each time so
// that no warp is cached); 2: a view at a cached aspect (pans at z = 0.5: traditional zoom only).
void BM_RetargetZoom(benchmark::State& state, int which) {
  Subject& s = subjects()[which];
  const warp::ImageModel& model = s.icaz->model();
  static std::unique_ptr<warp::RetargetZoom> engine;
  if (!engine) engine = std::make_unique<warp::RetargetZoom>(model, model.significance);
  int i = 0;
  double iterations = 0;
  for (auto _ : state) {
    warp::ViewRequest r;
    r.cx = s.width * (0.1 + 0.8 * ((i * 37) % 100) / 100.0), r.cy = s.height / 2;
    switch (state.range(0)) {
      case 0: benchmark::DoNotOptimize(warp::RetargetZoom(model, model.significance)); break;
      case 1:
        r.screen_width = 360 + i;
        iterations += engine->view(r).coarse_stats.iterations;
        break;
      default: r.zoom = 0.5, benchmark::DoNotOptimize(engine->view(r));
    }
    ++i;
  }
  state.counters["vertices"] = double(engine->mesh().vertices.size());
  state.counters["iterations"] = benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
  state.SetLabel(s.name + (state.range(0) == 0 ? ", load" : state.range(0) == 1 ? ", new aspect" : ", cached aspect"));
}

// kMaxLines lines summing to kMaxTotalLineLength × the larger side, on an 8 × 8 grid of centres
// (jittered so that no two lines are collinear): horizontal, vertical and oblique (30°) in turn.
std::vector<warp::Segment> max_lines(double w, double h) {
  namespace limits = warp::limits;
  const double len = limits::kMaxTotalLineLength / limits::kMaxLines * std::max(w, h);
  std::vector<warp::Segment> out;
  for (int i = 0; i < limits::kMaxLines; ++i) {
    const double cx = w * (0.1 + 0.8 * (i % 8) / 7 + 0.003 * i), cy = h * (0.1 + 0.8 * (i / 8) / 7 + 0.002 * i);
    const double angle = (i % 3 == 0 ? 0 : i % 3 == 1 ? 90 : 30) * M_PI / 180;
    const double dx = std::cos(angle) * len / 2, dy = std::sin(angle) * len / 2;
    out.push_back({{cx - dx, cy - dy}, {cx + dx, cy + dy}});
  }
  return out;
}

// Views (zoom actions along the range and pans) with 0 or kMaxLines lines: arg 0 = 0 lines.
void BM_Lines(benchmark::State& state) {
  static std::unique_ptr<warp::Icaz> engines[2];
  const Subject& s = subjects()[0];
  const int with = state.range(0) ? 1 : 0;
  if (!engines[with])
    engines[with] = std::make_unique<warp::Icaz>(
        warp::make_image_model(s.reduced, s.width, s.height, with ? max_lines(s.width, s.height) : std::vector<warp::Segment>{}));
  int i = 0;
  double iterations = 0;
  for (auto _ : state) {
    warp::ViewRequest r;
    r.zoom = 0.1 * (i % 11) + 1e-4 * (i / 11 % 50);
    r.cx = s.width * (0.1 + 0.8 * ((i * 37) % 100) / 100.0), r.cy = s.height * (0.2 + 0.6 * ((i * 61) % 100) / 100.0);
    ++i;
    iterations += engines[with]->view(r).fine_stats.iterations;
  }
  state.counters["fine_iterations"] = benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
  state.SetLabel(s.name + (with ? ", 64 lines" : ", no lines"));
}

// The largest screen of limits.h on a 4:1 panorama, zoomed out (and at z = 0.5).
void BM_BigScreen(benchmark::State& state) {
  static std::unique_ptr<warp::Icaz> pano;
  if (!pano) {
    const tiles::Raster full = testing::load_image(testing::samples_dir() + "/pano_grossmugl_field_4to1.png");
    pano = std::make_unique<warp::Icaz>(warp::make_image_model(reduce(full, 1024), full.width, full.height));
  }
  const double z = state.range(0) / 100.0;
  int i = 0;
  std::size_t vertices = 0;
  for (auto _ : state) {
    warp::ViewRequest r;
    r.zoom = z + 1e-4 * (i++ % 50);
    r.cx = pano->model().width / 2, r.cy = pano->model().height / 2;
    r.screen_width = r.screen_height = warp::limits::kMaxScreenSide;
    vertices = pano->view(r).source.vertices.size();
  }
  state.counters["vertices"] = double(vertices);
  state.SetLabel("pano 4:1, 4096×4096");
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::string image = argc > 1 ? argv[1] : testing::samples_dir() + "/../../shared/corpus/world_satellite_map.jpg";
  if (!std::filesystem::exists(image)) image = testing::samples_dir() + "/boats_lake_sunset.jpg";
  const tiles::Raster full = testing::load_image(image);
  Subject photo{std::filesystem::path(image).filename().string(), reduce(full, 1024), double(full.width),
                double(full.height), nullptr};
  // A 24576 × 12800 (315 MP) mosaic of the photo, 4 × 4 cells (mirrored alternately), at 1024 px.
  const tiles::Raster cell = reduce(full, 256);
  tiles::Raster mosaic(cell.width * 4, cell.height * 4, cell.channels);
  for (int y = 0; y < mosaic.height; ++y)
    for (int x = 0; x < mosaic.width; ++x) {
      const int cx = x / cell.width, cy = y / cell.height;
      const int sx = (cx + cy) % 2 ? cell.width - 1 - x % cell.width : x % cell.width;
      std::copy_n(cell.row(y % cell.height) + sx * cell.channels, cell.channels, mosaic.row(y) + x * cell.channels);
    }
  Subject big{"mosaic_24576x12800", reduce(mosaic, 1024), 24576, 12800, nullptr};
  subjects().push_back(std::move(photo));
  subjects().push_back(std::move(big));
  for (auto& s : subjects()) s.icaz = std::make_unique<warp::Icaz>(warp::make_image_model(s.reduced, s.width, s.height));

  for (int which = 0; which < 2; ++which) {
    const std::string tag = which == 0 ? "photo" : "mosaic";
    benchmark::RegisterBenchmark(("BuildModel/" + tag).c_str(), BM_BuildModel, which)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("Zoom/" + tag).c_str(), BM_Zoom, which)->DenseRange(0, 100, 20)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("Pan/" + tag).c_str(), BM_Pan, which)->DenseRange(0, 100, 20)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("Geomorph/" + tag).c_str(), BM_Geomorph, which)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
  }
  benchmark::RegisterBenchmark("UniformMeshZoom/photo", BM_UniformMeshZoom, 0)->Arg(50)->Unit(benchmark::kMillisecond)->Iterations(3);
  benchmark::RegisterBenchmark("RetargetZoom/photo", BM_RetargetZoom, 0)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(5);
  benchmark::RegisterBenchmark("Lines/photo", BM_Lines)->Arg(0)->Arg(warp::limits::kMaxLines)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BigScreen/pano", BM_BigScreen)->Arg(0)->Arg(50)->Unit(benchmark::kMillisecond)->Iterations(3);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
