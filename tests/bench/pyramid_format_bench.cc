// Measures the candidate on-disk pyramid formats on a real photograph: ingest time, bytes on disk,
// and the time to read one 256×256 tile that is not in the decoded-tile cache. The choice and the
// figures are written up in tiles/README.md.
//
//   build/bin/pyramid_format_bench [IMAGE]   (default: the bundled sample)
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <random>

#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "tiles/pyramid_reader.h"

namespace {

namespace fs = std::filesystem;
using namespace zoomwarp;

std::string g_image;

std::uint64_t folder_bytes(const std::string& dir) {
  std::uint64_t total = 0;
  for (auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) total += e.file_size();
  return total;
}

void BM_Ingest(benchmark::State& state, std::string compression) {
  testing::TempDir dir;
  tiles::Store store(dir.path());
  tiles::IngestOptions options;
  options.pyramid.compression = compression;
  tiles::Manifest m;
  for (auto _ : state) m = tiles::ingest_image(store, g_image, "img", options);
  state.counters["MB_on_disk"] = double(folder_bytes(store.find("img")->files->location())) / 1e6;
  state.counters["megapixels"] = double(m.width) * m.height / 1e6;
  state.counters["MP_per_s"] = benchmark::Counter(double(m.width) * m.height / 1e6 * double(state.iterations()),
                                                  benchmark::Counter::kIsRate);
}

// A tile read from disk: the cache is far smaller than the image, and tiles are visited at random.
void BM_ReadUncachedTile(benchmark::State& state, std::string compression) {
  testing::TempDir dir;
  tiles::Store store(dir.path());
  tiles::IngestOptions options;
  options.pyramid.compression = compression;
  tiles::ingest_image(store, g_image, "img", options);
  auto entry = store.find("img");
  tiles::PyramidReader reader(1 << 20);
  const auto& m = entry->manifest;
  const int cols = m.width / 256, rows = m.height / 256;
  std::mt19937 rng(1);
  for (auto _ : state) {
    const int c = int(rng() % cols), r = int(rng() % rows);
    benchmark::DoNotOptimize(reader.read_level(*entry, 0, {c * 256LL, r * 256LL, 256, 256}));
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  g_image = argc > 1 ? argv[1] : testing::samples_dir() + "/boats_lake_sunset.jpg";
  for (const char* c : {"none", "lzw", "zip:1", "zip"}) {
    benchmark::RegisterBenchmark((std::string("Ingest/") + c).c_str(), BM_Ingest, std::string(c))
        ->Unit(benchmark::kMillisecond)
        ->Iterations(2);
    benchmark::RegisterBenchmark((std::string("ReadUncachedTile/") + c).c_str(), BM_ReadUncachedTile, std::string(c))
        ->Unit(benchmark::kMicrosecond);
  }
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
