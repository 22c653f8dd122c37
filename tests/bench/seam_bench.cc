// Seam carving's costs (method=seam, warp/methods/seam/): the precomputation — both visibility
// maps by liblqr — at the analysis sizes of a 16:9 and a 4:3 photo (1024×576, 1024×768), carved
// at that size and reduced as ingest carves them (compute_seam_maps), and
// what a request costs: a carve table for a new screen aspect, and a rendered 480×360 / 360×640
// screen at zoom 0 and 0.5 from an ingested pyramid.
//
//   build/bin/seam_bench [IMAGE]   (default: samples/boats_lake_sunset.jpg, 2560×1600)
#include <benchmark/benchmark.h>

#include <memory>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "warp/analysis/analysis_image.h"
#include "warp/methods/seam/seam_carving.h"
#include "warp/methods/seam/seam_resolution.h"
#include "warp/saliency/significance.h"

namespace {

using namespace zoomwarp;

std::string& image_path() {
  static std::string path = testing::samples_dir() + "/boats_lake_sunset.jpg";
  return path;
}

warp::SignificanceMap significance_of(const tiles::Raster& image) {
  warp::SignificanceOptions no_faces;
  no_faces.face_cascade = "";
  return warp::compute_significance(image, image.width, no_faces);
}

void BM_VisibilityMaps(benchmark::State& state) {
  const tiles::Raster image =
      testing::resize(testing::load_image(image_path()), int(state.range(0)), int(state.range(1)));
  const warp::SignificanceMap saliency = significance_of(image);
  for (auto _ : state) benchmark::DoNotOptimize(warp::compute_visibility_maps(image, saliency));
}
BENCHMARK(BM_VisibilityMaps)->Args({1024, 576})->Args({1024, 768})->Unit(benchmark::kMillisecond)->Iterations(2);

// What ingest pays per seam.<saliency>.bin: the same analysis images carved reduced to a long
// side of kSeamMaxSide (seam_resolution.h).
void BM_SeamMaps(benchmark::State& state) {
  const tiles::Raster image =
      testing::resize(testing::load_image(image_path()), int(state.range(0)), int(state.range(1)));
  const warp::SignificanceMap saliency = significance_of(image);
  for (auto _ : state) benchmark::DoNotOptimize(warp::compute_seam_maps(image, saliency));
}
BENCHMARK(BM_SeamMaps)->Args({1024, 576})->Args({1024, 768})->Unit(benchmark::kMillisecond)->Iterations(2);

// An ingested image, its engine from the stored maps, and a reader: what a server holds.
struct Served {
  testing::TempDir dir;
  std::unique_ptr<tiles::Store> store;
  std::shared_ptr<const tiles::ImageEntry> entry;
  tiles::PyramidReader reader{256 << 20};
  std::unique_ptr<warp::SeamCarving> engine;

  Served() {
    store = std::make_unique<tiles::Store>(dir.path() + "/store");
    tiles::ingest_image(*store, image_path(), "img", {}, {});
    entry = store->find("img");
    const tiles::Raster analysis = warp::read_reduced_image(*entry, reader);
    engine = std::make_unique<warp::SeamCarving>(entry->manifest.width, entry->manifest.height,
                                                 warp::compute_visibility_maps(analysis, significance_of(analysis)));
  }
};

Served& served() {
  static Served s;
  return s;
}

// A new screen aspect per iteration: the carve table is never cached.
void BM_CarveTable(benchmark::State& state) {
  Served& s = served();
  int width = 200;
  for (auto _ : state) benchmark::DoNotOptimize(s.engine->carved(width++ % 600 + 200, 640));
}
BENCHMARK(BM_CarveTable)->Unit(benchmark::kMillisecond);

void BM_Render(benchmark::State& state) {
  Served& s = served();
  warp::ViewRequest r;
  r.screen_width = int(state.range(0)), r.screen_height = int(state.range(1));
  r.zoom = state.range(2) / 100.0;
  r.cx = s.entry->manifest.width / 2.0, r.cy = s.entry->manifest.height / 2.0;
  for (auto _ : state) benchmark::DoNotOptimize(s.engine->render(r, *s.entry, s.reader));
}
BENCHMARK(BM_Render)
    ->Args({480, 360, 0})
    ->Args({480, 360, 50})
    ->Args({360, 640, 0})
    ->Args({360, 640, 50})
    ->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (argc > 1) image_path() = argv[1];
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
