// What each answer format costs to encode, and what it gives (issue 31: "a format that is too
// slow to serve at request time is reported, not offered"): a 480×360 view of the boats sample,
// as /viewport answers it, encoded as JPEG, WebP, AVIF and JPEG XL at several qualities and, for
// AVIF and JPEG XL, encoder speeds (efforts). Counters: bytes, and PSNR of the decoded answer against the view (dB), so that
// sizes and times are compared at matched quality.
//
//   build/bin/encode_bench [--benchmark_filter=Avif|Jxl]
#include <benchmark/benchmark.h>

#include <string>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/encode.h"

namespace zoomwarp {
namespace {

const tiles::Raster& view() {
  static const tiles::Raster v = testing::resize(
      testing::crop(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"), {320, 160, 1920, 1440}), 480, 360);
  return v;
}

// The answer decoded by OpenImageIO (libjpeg, libwebp, libheif) or libjxl, against the view.
double psnr_of(const std::string& bytes) { return testing::psnr(testing::decode_image(bytes), view()); }

void Encode(benchmark::State& state, tiles::ImageFormat format, int quality, int speed) {
  tiles::EncodeOptions options;
  options.jpeg_quality = options.webp_quality = options.avif_quality = options.jxl_quality = quality;
  options.avif_speed = speed;
  options.jxl_effort = speed;
  std::string bytes;
  view();  // decoded once, outside the timing
  for (auto _ : state) {
    bytes = tiles::encode_image(view(), format, options);
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["bytes"] = double(bytes.size());
  state.counters["psnr_db"] = psnr_of(bytes);
}

void register_all() {
  using tiles::ImageFormat;
  for (int q : {75, 85, 90}) benchmark::RegisterBenchmark(("Jpeg/q" + std::to_string(q)).c_str(), Encode, ImageFormat::kJpeg, q, 0);
  for (int q : {70, 80, 90}) benchmark::RegisterBenchmark(("Webp/q" + std::to_string(q)).c_str(), Encode, ImageFormat::kWebp, q, 0);
  for (int speed : {6, 8, 10})
    for (int q : {50, 60, 70})
      benchmark::RegisterBenchmark(("Avif/speed" + std::to_string(speed) + "/q" + std::to_string(q)).c_str(), Encode,
                                   ImageFormat::kAvif, q, speed)
          ->Unit(benchmark::kMillisecond);
  for (int effort : {1, 3, 5})
    for (int q : {70, 80, 85, 90})
      benchmark::RegisterBenchmark(("Jxl/effort" + std::to_string(effort) + "/q" + std::to_string(q)).c_str(), Encode,
                                   ImageFormat::kJxl, q, effort)
          ->Unit(benchmark::kMillisecond);
}

}  // namespace
}  // namespace zoomwarp

int main(int argc, char** argv) {
  zoomwarp::register_all();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
