// The saliency maps' compact payload (warp/analysis/compact_map.h, issue 28): two bytes per value,
// round trips within half a step of 1/65535 — exactly for a map at the maps' precision, as every
// computed map is — and damaged bytes are a ModelFileError.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/analysis/compact_map.h"
#include "warp/analysis/model_file.h"
#include "warp/saliency/gbvs.h"
#include "warp/saliency/precision.h"

namespace zoomwarp {
namespace {

warp::SignificanceMap random_map(int w, int h) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0, 1);
  warp::SignificanceMap m;
  m.width = w, m.height = h, m.scale = 0.25;
  for (int i = 0; i < w * h; ++i) m.values.push_back(u(rng));
  return m;
}

TEST(CompactMap, AnyMapRoundTripsWithinHalfAStep) {
  warp::SignificanceMap m = random_map(97, 61);
  m.values[0] = 0, m.values[1] = 1, m.values[2] = -0.5f, m.values[3] = 1.5f;  // clamped to [0, 1]
  const warp::SignificanceMap back = warp::parse_compact_map("m.bin", warp::compact_map_bytes(m));
  ASSERT_EQ(back.width, 97);
  ASSERT_EQ(back.height, 61);
  EXPECT_EQ(back.scale, 0.25);
  ASSERT_EQ(back.values.size(), m.values.size());
  EXPECT_EQ(back.values[2], 0.0f);
  EXPECT_EQ(back.values[3], 1.0f);
  for (std::size_t i = 4; i < m.values.size(); ++i)
    ASSERT_LE(std::abs(back.values[i] - m.values[i]), 0.5f / warp::kSignificanceLevels + 1e-7f) << i;
}

// Every map the analysis makes is at the maps' precision: stored and read back, it is the same
// map value for value (so a map rebuilt in memory is the stored one). Both kinds, a photo.
TEST(CompactMap, ComputedMapsRoundTripExactlyAndSmall) {
  const tiles::Raster image = testing::resize(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"), 1024, 640);
  warp::SignificanceOptions no_faces;
  no_faces.face_cascade = "";
  for (const warp::SignificanceMap& m :
       {warp::compute_significance(image, 2560, no_faces), warp::gbvs_significance(image, 2560, no_faces)}) {
    const std::string bytes = warp::compact_map_bytes(m);
    const warp::SignificanceMap back = warp::parse_compact_map("m.bin", bytes);
    EXPECT_TRUE(back.values == m.values);
    std::printf("[ figures ] %dx%d map: %zu bytes as floats, %zu compact\n", m.width, m.height,
                m.values.size() * sizeof(float), bytes.size());
    EXPECT_LT(bytes.size(), m.values.size() * 8 / 5) << "under 1.6 bytes per value (floats: 4)";
  }
}

TEST(CompactMap, DamagedBytesAreAModelFileError) {
  const std::string bytes = warp::compact_map_bytes(random_map(40, 30));
  EXPECT_THROW(warp::parse_compact_map("m.bin", bytes.substr(0, bytes.size() - 5)), warp::ModelFileError);
  EXPECT_THROW(warp::parse_compact_map("m.bin", bytes.substr(0, 10)), warp::ModelFileError);
  std::string wider = bytes;
  wider[0] = 41;  // 41 × 30 values stated, 40 × 30 stored
  EXPECT_THROW(warp::parse_compact_map("m.bin", wider), warp::ModelFileError);
}

}  // namespace
}  // namespace zoomwarp
