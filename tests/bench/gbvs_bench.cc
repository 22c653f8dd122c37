// The cost of saliency=gbvs: GBVS [Harel06] of the analysis image (≤ 1024 px; 21 feature maps, two
// Markov chains each on a grid of larger side 32), the default map next to it for comparison,
// and ICAZ's node means recomputed from another map (what a gbvs engine adds to loading a model).
//
//   build/bin/gbvs_bench [IMAGE]   (default: samples/boats_lake_sunset.jpg, 2560×1600)
#include <benchmark/benchmark.h>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/icaz/image_model.h"
#include "warp/saliency/gbvs.h"

namespace {

using namespace zoomwarp;

struct Subject {
  tiles::Raster reduced;  // the analysis image
  int width = 0, height = 0;
};

Subject& subject() {
  static Subject s;
  return s;
}

void BM_Gbvs(benchmark::State& state) {
  const Subject& s = subject();
  for (auto _ : state) benchmark::DoNotOptimize(warp::compute_gbvs(s.reduced, s.width, s.reduced.width, s.reduced.height));
}

void BM_DefaultSignificance(benchmark::State& state) {
  const Subject& s = subject();
  warp::SignificanceOptions no_faces;
  no_faces.face_cascade = "";
  for (auto _ : state) benchmark::DoNotOptimize(warp::compute_significance(s.reduced, s.width, no_faces));
}

void BM_NodeMeansFromAnotherMap(benchmark::State& state) {
  const Subject& s = subject();
  warp::ImageModel model = warp::make_image_model(s.reduced, s.width, s.height);
  const warp::SignificanceMap gbvs = warp::compute_gbvs(s.reduced, s.width, s.reduced.width, s.reduced.height);
  for (auto _ : state) warp::set_significance(model, gbvs);
  state.SetLabel(std::to_string(model.forest.kept_nodes()) + " nodes");
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  const std::string path = argc > 1 ? argv[1] : testing::samples_dir() + "/boats_lake_sunset.jpg";
  const tiles::Raster full = testing::load_image(path);
  const double f = std::min(1.0, double(warp::kSignificanceMaxSide) / std::max(full.width, full.height));
  subject() = {testing::resize(full, std::max(1, int(full.width * f)), std::max(1, int(full.height * f))), full.width,
               full.height};
  std::printf("%s: %dx%d, analysis image %dx%d\n", path.c_str(), full.width, full.height, subject().reduced.width,
              subject().reduced.height);
  benchmark::RegisterBenchmark("Gbvs", BM_Gbvs)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("DefaultSignificance", BM_DefaultSignificance)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("NodeMeansFromAnotherMap", BM_NodeMeansFromAnotherMap)->Unit(benchmark::kMillisecond);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
