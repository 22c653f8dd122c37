// GBVS [Harel06] against what the method is known to do, not against its own earlier output: a
// lone bright blob is the most salient place, a colour singleton pops out among distractors of
// the same shape; the Markov chain's equilibrium is a distribution that P leaves in place (and,
// for symmetric weights, the degree distribution, by detailed balance). [Kumar (004) §III-B]
// object selection: Otsu's region covers the object, the attention value favours the centre.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/saliency/attention.h"
#include "warp/saliency/gbvs.h"

namespace zoomwarp {
namespace {

using Rgb = std::array<std::uint8_t, 3>;

tiles::Raster field(int w, int h, Rgb colour) {
  tiles::Raster r(w, h, 3);
  for (std::size_t i = 0; i < r.pixels.size(); i += 3) std::copy(colour.begin(), colour.end(), r.pixels.begin() + i);
  return r;
}

void disc(tiles::Raster& r, double cx, double cy, double radius, Rgb colour) {
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x)
      if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= radius)
        std::copy(colour.begin(), colour.end(), r.row(y) + std::size_t(x) * 3);
}

double mean_over_disc(const warp::SignificanceMap& m, double cx, double cy, double radius) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x)
      if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= radius) sum += m.at(x, y), ++n;
  return sum / n;
}

constexpr Rgb kGrey = {128, 128, 128};

TEST(Gbvs, ALoneBrightBlobOnAUniformFieldIsTheMaximum) {
  // Off centre, so that the graph's own preference for the centre cannot be what finds it.
  tiles::Raster img = field(320, 240, kGrey);
  const double bx = 80, by = 70, radius = 14;
  disc(img, bx, by, radius, {255, 255, 255});
  const warp::SignificanceMap m = warp::compute_gbvs(img, 320, 320, 240);
  const auto top = std::max_element(m.values.begin(), m.values.end());
  const int i = int(top - m.values.begin());
  EXPECT_FLOAT_EQ(*top, 1.0f);
  EXPECT_LE(std::hypot(i % m.width + 0.5 - bx, i / m.width + 0.5 - by), radius)
      << "maximum at " << i % m.width << "," << i / m.width;
  EXPECT_GT(mean_over_disc(m, bx, by, radius), 3 * mean_over_disc(m, 240, 170, radius)) << "against empty field";
}

TEST(Gbvs, AColourSingletonPopsOutAmongDistractorsOfTheSameShape) {
  // Eight equal discs of equal intensity on a ring around the centre, so that the graph's centre
  // preference is the same for all: one red, seven blue. Only the colour sets the target apart:
  // the red–green map holds it alone, the blue–yellow map all seven distractors. (Red among
  // green would not pop out here: in the signed red–green map both differ from the grey by as
  // much, and GBVS compares magnitudes of differences.)
  tiles::Raster img = field(320, 320, kGrey);
  const double ring = 100, r = 16;
  auto centre = [&](int k) { return std::pair{160 + ring * std::cos(k * M_PI / 4), 160 + ring * std::sin(k * M_PI / 4)}; };
  const int target = 3;
  for (int k = 0; k < 8; ++k)
    disc(img, centre(k).first, centre(k).second, r, k == target ? Rgb{200, 0, 0} : Rgb{0, 0, 200});
  const warp::SignificanceMap m = warp::compute_gbvs(img, 320, 320, 320);
  const double on_target = mean_over_disc(m, centre(target).first, centre(target).second, r);
  for (int k = 0; k < 8; ++k) {
    if (k == target) continue;
    SCOPED_TRACE("distractor " + std::to_string(k));
    EXPECT_GT(on_target, 1.5 * mean_over_disc(m, centre(k).first, centre(k).second, r));
  }
}

TEST(Gbvs, NormalisationGathersASingletonsMassOntoItNotItsNeighbours) {
  // [Harel06]: activation is high wherever a location differs from what is around it, the
  // surround of a peak included; the normalisation chain moves the mass onto the peaks. Eight
  // equal discs on a ring: one light grey (an intensity singleton), seven red of the background's
  // intensity (seen by the colour maps only). Without normalisation the singleton's activation
  // spills onto the discs next to it (they had 2× the mean of those across the ring).
  tiles::Raster img = field(320, 320, {85, 85, 85});
  const double ring = 100, r = 16;
  auto mean_at = [&](const warp::SignificanceMap& m, int k) {
    return mean_over_disc(m, 160 + ring * std::cos(k * M_PI / 4), 160 + ring * std::sin(k * M_PI / 4), r);
  };
  const int target = 3;
  for (int k = 0; k < 8; ++k)
    disc(img, 160 + ring * std::cos(k * M_PI / 4), 160 + ring * std::sin(k * M_PI / 4), r,
         k == target ? Rgb{170, 170, 170} : Rgb{255, 0, 0});
  const warp::SignificanceMap m = warp::compute_gbvs(img, 320, 320, 320);
  for (int k = 0; k < 8; ++k) {
    if (k == target) continue;
    EXPECT_GT(mean_at(m, target), 10 * mean_at(m, k)) << "distractor " << k;
  }
  const double next_to_it = (mean_at(m, 2) + mean_at(m, 4)) / 2, across = (mean_at(m, 6) + mean_at(m, 7) + mean_at(m, 0)) / 3;
  EXPECT_LT(next_to_it, 1.5 * across);
}

// P = w with rows normalised: the chain's transition matrix.
std::vector<double> transitions(const std::vector<double>& w, int n) {
  std::vector<double> p = w;
  for (int i = 0; i < n; ++i) {
    double s = 0;
    for (int j = 0; j < n; ++j) s += w[std::size_t(i) * n + j];
    for (int j = 0; j < n; ++j) p[std::size_t(i) * n + j] /= s;
  }
  return p;
}

double residual(const std::vector<double>& p, const std::vector<double>& pi) {
  const int n = int(pi.size());
  double worst = 0;
  for (int j = 0; j < n; ++j) {
    double v = 0;
    for (int i = 0; i < n; ++i) v += pi[i] * p[std::size_t(i) * n + j];
    worst = std::max(worst, std::abs(v - pi[j]));
  }
  return worst;
}

TEST(Gbvs, StationaryDistributionIsOneThatTheChainLeavesInPlace) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.01, 1);
  const int n = 60;
  std::vector<double> w(std::size_t(n) * n);
  for (double& v : w) v = u(rng);  // not symmetric: the normalisation graph's kind
  const std::vector<double> pi = warp::stationary_distribution(w, n);
  double sum = 0;
  for (double v : pi) {
    EXPECT_GT(v, 0);
    sum += v;
  }
  EXPECT_NEAR(sum, 1, 1e-12);
  EXPECT_LT(residual(transitions(w, n), pi), 1e-4);
}

TEST(Gbvs, SymmetricWeightsGiveTheDegreeDistributionAndATwoValuedMapConverges) {
  // Detailed balance: with w symmetric, π_i = Σ_j w_ij / Σ w. The two-valued map's graph is
  // bipartite (weights only between the values), where plain power iteration from anywhere but
  // π oscillates: started from the uniform vector here.
  const int n = 40;
  std::vector<double> w(std::size_t(n) * n, 0.0);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if ((i < 10) != (j < 10)) w[std::size_t(i) * n + j] = std::exp(-std::abs(i - j) / 8.0);
  const std::vector<double> pi = warp::stationary_distribution(w, n, 1e-4, 1000, std::vector<double>(n, 1.0));
  double total = 0;
  for (double v : w) total += v;
  for (int i = 0; i < n; ++i) {
    double degree = 0;
    for (int j = 0; j < n; ++j) degree += w[std::size_t(i) * n + j];
    EXPECT_NEAR(pi[i], degree / total, 1e-4) << i;
  }
  EXPECT_LT(residual(transitions(w, n), pi), 1e-4);
}

TEST(Gbvs, IsDeterministicBoundedAndCopesWithDegenerateImages) {
  const tiles::Raster img = testing::load_image(testing::samples_dir() + "/astronaut_portrait.png");
  const warp::SignificanceMap a = warp::compute_gbvs(img, 1024, 512, 512), b = warp::compute_gbvs(img, 1024, 512, 512);
  EXPECT_TRUE(a.values == b.values);
  EXPECT_DOUBLE_EQ(a.scale, 0.5);
  const auto [lo, hi] = std::minmax_element(a.values.begin(), a.values.end());
  EXPECT_FLOAT_EQ(*lo, 0.0f);
  EXPECT_FLOAT_EQ(*hi, 1.0f);
  for (auto [w, h] : {std::pair{1, 1}, {1, 300}, {700, 2}, {5, 5}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    tiles::Raster tiny = field(w, h, kGrey);
    tiny.pixels[0] = 255;
    const warp::SignificanceMap m = warp::compute_gbvs(tiny, w, w, h);
    EXPECT_EQ(m.values.size(), std::size_t(w) * h);
    for (float v : m.values) EXPECT_TRUE(v >= 0 && v <= 1);
  }
  // Nothing stands out: what is left is the graph's preference for the centre (border locations
  // have fewer near neighbours).
  const warp::SignificanceMap flat = warp::compute_gbvs(field(64, 48, kGrey), 64, 64, 48);
  const auto peak = std::max_element(flat.values.begin(), flat.values.end()) - flat.values.begin();
  EXPECT_NEAR(peak % 64, 32, 3);
  EXPECT_NEAR(peak / 64, 24, 3);
  EXPECT_LT(flat.at(0, 0), 0.05f);
  EXPECT_THROW(warp::compute_gbvs(tiles::Raster{}, 1, 1, 1), std::invalid_argument);
}

TEST(Attention, OtsusRegionCoversAColouredDiscOnGrey) {
  tiles::Raster img = field(320, 240, kGrey);
  const double cx = 120, cy = 100, radius = 30;
  disc(img, cx, cy, radius, {30, 60, 220});
  const warp::SignificanceMap m = warp::compute_gbvs(img, 320, 320, 240);
  const auto top = std::max_element(m.values.begin(), m.values.end()) - m.values.begin();
  EXPECT_LE(std::hypot(top % m.width + 0.5 - cx, top / m.width + 0.5 - cy), radius) << "the maximum is on the disc";
  const warp::AttentionRegions regions = warp::attention_regions(m);
  const int label = regions.labels[std::size_t(cy) * m.width + std::size_t(cx)];
  ASSERT_GT(label, 0) << "the disc's centre is above the threshold";
  long long both = 0, either = 0;
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      const bool in_disc = std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= radius;
      const bool in_region = regions.labels[std::size_t(y) * m.width + x] == label;
      both += in_disc && in_region;
      either += in_disc || in_region;
    }
  EXPECT_GT(double(both) / either, 0.5);
}

TEST(Attention, EqualObjectsRankByTheirDistanceFromTheCentre) {
  warp::SignificanceMap m;
  m.width = 200, m.height = 150, m.scale = 1;
  m.values.assign(std::size_t(m.width) * m.height, 0.1f);
  auto blob = [&](double cx, double cy) {
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x)
        if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= 12) m.values[std::size_t(y) * m.width + x] = 0.9f;
  };
  blob(100, 75);  // centre
  blob(40, 35);   // towards the top-left corner
  const warp::AttentionRegions r = warp::attention_regions(m);
  ASSERT_EQ(r.regions.size(), 2u);
  const int centre = r.labels[75 * 200 + 100], corner = r.labels[35 * 200 + 40];
  ASSERT_TRUE(centre > 0 && corner > 0 && centre != corner);
  const double av_centre = r.regions[std::size_t(centre - 1)].attention, av_corner = r.regions[std::size_t(corner - 1)].attention;
  EXPECT_GT(av_centre, av_corner);
  EXPECT_EQ(r.regions[std::size_t(centre - 1)].area, r.regions[std::size_t(corner - 1)].area) << "equal objects";
  EXPECT_GT(r.threshold, 0.1f);
  EXPECT_LT(r.threshold, 0.9f);
  // AV sums B·W over the region with ΣW = 1: at most the region's largest value.
  EXPECT_LT(av_centre, 0.9);
  EXPECT_EQ(r.kept(av_corner / av_centre * 1.01).size(), 1u);
  EXPECT_EQ(r.kept(0.1).size(), 2u);
  m.values.assign(m.values.size(), 0.5f);
  EXPECT_TRUE(warp::attention_regions(m).regions.empty()) << "a flat map has no object";
}

}  // namespace
}  // namespace zoomwarp
