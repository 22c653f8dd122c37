#include "warp/methods/patch/patch_segmentation.h"

#include <algorithm>
#include <boost/pending/disjoint_sets.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <opencv2/imgproc.hpp>
#include <queue>
#include <set>
#include <tuple>

namespace zoomwarp::warp {

namespace {

using Colour = std::array<double, 3>;

Colour colour_at(const tiles::Raster& image, int x, int y) {
  const std::uint8_t* p = image.row(y) + std::size_t(x) * image.channels;
  return image.channels >= 3 ? Colour{double(p[0]), double(p[1]), double(p[2])} : Colour{double(p[0]), double(p[0]), double(p[0])};
}

double distance(const Colour& a, const Colour& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

// The image as three float channels smoothed by a Gaussian of σ [Felzenszwalb04 §5: it
// removes digitisation artefacts before the graph is built].
cv::Mat smoothed_rgb(const tiles::Raster& image, double sigma) {
  cv::Mat rgb(image.height, image.width, CV_32FC3);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const Colour c = colour_at(image, x, y);
      rgb.at<cv::Vec3f>(y, x) = cv::Vec3f(float(c[0]), float(c[1]), float(c[2]));
    }
  if (sigma > 0) cv::GaussianBlur(rgb, rgb, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  return rgb;
}

struct Edge {
  float weight;
  int a, b;  // pixel indices, a < b
};

// The 8-neighbour grid graph: each pixel to its right, lower, lower-right and upper-right
// neighbours, weighted by the Euclidean distance of their smoothed colours, in increasing weight
// and, for equal weights, in grid order (pixel by pixel, the four neighbours in that order), so
// that the segmentation is deterministic.
//
// Each edge is kept as one 64-bit key — its weight's bits (a non-negative float orders as its bit
// pattern does) above its place in grid order (pixel × 4 + neighbour) — and the keys are sorted in
// place: the order a stable sort of the edges gives, in 8 bytes an edge instead of 12 plus the
// stable sort's buffer of as many again. That buffer made segmentation the analysis's largest
// job: 90 MB of edges on a 996×934 analysis image (issue 18).
class GridEdges {
 public:
  explicit GridEdges(const cv::Mat& rgb) : w_(rgb.cols) {
    const int h = rgb.rows;
    if (std::uint64_t(w_) * std::uint64_t(h) * 4 > UINT32_MAX) throw std::length_error("image too large to segment");
    keys_.reserve(std::size_t(w_) * h * 4);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w_; ++x)
        for (int n = 0; n < 4; ++n) {
          const auto [dx, dy] = kNeighbour[n];
          if (x + dx >= w_ || y + dy < 0 || y + dy >= h) continue;
          const cv::Vec3f d = rgb.at<cv::Vec3f>(y, x) - rgb.at<cv::Vec3f>(y + dy, x + dx);
          const float weight = std::sqrt(d.dot(d));
          std::uint32_t bits;
          std::memcpy(&bits, &weight, sizeof bits);
          keys_.push_back(std::uint64_t(bits) << 32 | (std::uint32_t(y * w_ + x) * 4 + std::uint32_t(n)));
        }
    std::sort(keys_.begin(), keys_.end());
  }

  std::size_t size() const { return keys_.size(); }
  Edge operator[](std::size_t i) const {
    const std::uint64_t key = keys_[i];
    const auto bits = std::uint32_t(key >> 32), place = std::uint32_t(key);
    float weight;
    std::memcpy(&weight, &bits, sizeof weight);
    const int p = int(place / 4), x = p % w_, y = p / w_;
    const auto [dx, dy] = kNeighbour[place % 4];
    const int q = (y + dy) * w_ + x + dx;
    return {weight, std::min(p, q), std::max(p, q)};
  }

 private:
  static constexpr std::pair<int, int> kNeighbour[4] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  int w_;
  std::vector<std::uint64_t> keys_;
};

// Union–find over n elements with component sizes (Boost's disjoint_sets keeps rank only).
class Components {
 public:
  explicit Components(int n) : rank_(n, 0), parent_(n), size_(n, 1), sets_(rank_.data(), parent_.data()) {
    for (int i = 0; i < n; ++i) sets_.make_set(i);
  }
  int find(int i) { return sets_.find_set(i); }
  int size(int root) const { return size_[root]; }
  // Joins the components of roots a and b; returns the new root.
  int join(int a, int b) {
    const int total = size_[a] + size_[b];
    sets_.link(a, b);
    const int root = sets_.find_set(a);
    size_[root] = total;
    return root;
  }

 private:
  std::vector<int> rank_, parent_, size_;
  boost::disjoint_sets<int*, int*> sets_;
};

// Patches from a union–find over pixels: labels numbered by first pixel, sizes, mean colours of
// the unsmoothed image.
Patches patches_of(Components& c, const tiles::Raster& image) {
  Patches p;
  p.width = image.width;
  p.height = image.height;
  const int n = image.width * image.height;
  p.label.assign(n, -1);
  std::vector<int> id_of_root(n, -1);
  for (int i = 0; i < n; ++i) {
    const int r = c.find(i);
    if (id_of_root[r] < 0) {
      id_of_root[r] = p.count++;
      p.size.push_back(0);
      p.mean_colour.push_back({0, 0, 0});
    }
    const int id = id_of_root[r];
    p.label[i] = id;
    ++p.size[id];
    const Colour col = colour_at(image, i % image.width, i / image.width);
    for (int k = 0; k < 3; ++k) p.mean_colour[id][k] += col[k];
  }
  for (int id = 0; id < p.count; ++id)
    for (int k = 0; k < 3; ++k) p.mean_colour[id][k] /= p.size[id];
  return p;
}

}  // namespace

Patches segment_graph(const tiles::Raster& image, const SegmentationOptions& options) {
  if (image.empty() || image.channels < 1) return {};
  const GridEdges edges(smoothed_rgb(image, options.sigma));
  const int n = image.width * image.height;
  Components c(n);
  // τ(C) = k/|C| [Felzenszwalb04 eq. 5]; threshold[root] = Int(C) + τ(C), Int(C) being the
  // weight of the last edge that joined C (edges come in increasing order).
  std::vector<double> threshold(n, options.k);
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const Edge e = edges[i];
    const int a = c.find(e.a), b = c.find(e.b);
    if (a == b || e.weight > threshold[a] || e.weight > threshold[b]) continue;
    const int root = c.join(a, b);
    threshold[root] = e.weight + options.k / c.size(root);
  }
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const Edge e = edges[i];
    const int a = c.find(e.a), b = c.find(e.b);
    if (a != b && (c.size(a) < options.min_size || c.size(b) < options.min_size)) c.join(a, b);
  }
  return patches_of(c, image);
}

std::vector<std::vector<int>> patch_adjacency(const Patches& p) {
  std::vector<std::set<int>> sets(p.count);
  const auto link = [&](int i, int j) {
    const int a = p.label[i], b = p.label[j];
    if (a != b) sets[a].insert(b), sets[b].insert(a);
  };
  for (int y = 0; y < p.height; ++y)
    for (int x = 0; x < p.width; ++x) {
      const int i = y * p.width + x;
      if (x + 1 < p.width) link(i, i + 1);
      if (y + 1 < p.height) link(i, i + p.width);
      if (x + 1 < p.width && y + 1 < p.height) link(i, i + p.width + 1);
      if (x + 1 < p.width && y > 0) link(i, i - p.width + 1);
    }
  std::vector<std::vector<int>> out(p.count);
  for (int a = 0; a < p.count; ++a) out[a].assign(sets[a].begin(), sets[a].end());
  return out;
}

Patches merge_patches(const Patches& in, const SegmentationOptions& options) {
  if (in.count == 0) return in;
  // Patches as union–find roots with their pixel counts, colour sums and neighbour sets.
  std::vector<int> parent(in.count);
  std::iota(parent.begin(), parent.end(), 0);
  const auto root = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  std::vector<double> size(in.size.begin(), in.size.end());
  std::vector<Colour> sum(in.count);
  for (int i = 0; i < in.count; ++i)
    for (int k = 0; k < 3; ++k) sum[i][k] = in.mean_colour[i][k] * in.size[i];
  std::vector<std::set<int>> neighbours(in.count);
  {
    const auto adjacency = patch_adjacency(in);
    for (int i = 0; i < in.count; ++i) neighbours[i].insert(adjacency[i].begin(), adjacency[i].end());
  }
  const auto mean = [&](int r) { return Colour{sum[r][0] / size[r], sum[r][1] / size[r], sum[r][2] / size[r]}; };
  std::vector<int> version(in.count, 0);
  // Joins roots a and b (b into a: a keeps its index); returns a.
  const auto join = [&](int a, int b) {
    if (neighbours[a].size() < neighbours[b].size()) std::swap(a, b);
    parent[b] = a;
    size[a] += size[b];
    for (int k = 0; k < 3; ++k) sum[a][k] += sum[b][k];
    for (int n : neighbours[b]) {
      neighbours[n].erase(b);
      if (n != a) neighbours[n].insert(a), neighbours[a].insert(n);
    }
    neighbours[a].erase(b);
    neighbours[b].clear();
    ++version[a];
    return a;
  };

  // Small patches join the adjacent patch of nearest colour, smallest first, until none is left
  // (a patch with no neighbour — the whole image — stays).
  const double min_pixels = options.min_fraction * double(in.width) * in.height;
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<int> small;
    for (int i = 0; i < in.count; ++i)
      if (root(i) == i && size[i] < min_pixels && !neighbours[i].empty()) small.push_back(i);
    std::stable_sort(small.begin(), small.end(), [&](int a, int b) { return size[a] < size[b]; });
    for (int s : small) {
      if (root(s) != s || size[s] >= min_pixels || neighbours[s].empty()) continue;
      int best = -1;
      double best_d = 0;
      for (int n : neighbours[s]) {
        const double d = distance(mean(s), mean(n));
        if (best < 0 || d < best_d) best = n, best_d = d;
      }
      join(s, best);
      changed = true;
    }
  }

  // Similar neighbours merge, closest pair first; an entry is stale once either side changed.
  using Pair = std::tuple<double, int, int, int, int>;  // distance, a, b, version a, version b
  std::priority_queue<Pair, std::vector<Pair>, std::greater<>> queue;
  const auto offer = [&](int a) {
    for (int b : neighbours[a]) {
      const double d = distance(mean(a), mean(b));
      if (d < options.merge_distance) queue.emplace(d, std::min(a, b), std::max(a, b), version[std::min(a, b)], version[std::max(a, b)]);
    }
  };
  for (int i = 0; i < in.count; ++i)
    if (root(i) == i) offer(i);
  while (!queue.empty()) {
    const auto [d, a, b, va, vb] = queue.top();
    queue.pop();
    if (root(a) != a || root(b) != b || version[a] != va || version[b] != vb) continue;
    offer(join(a, b));
  }

  // Renumbered by first pixel.
  Patches out;
  out.width = in.width;
  out.height = in.height;
  out.label.resize(in.label.size());
  std::vector<int> id_of_root(in.count, -1);
  for (std::size_t i = 0; i < in.label.size(); ++i) {
    const int r = root(in.label[i]);
    if (id_of_root[r] < 0) {
      id_of_root[r] = out.count++;
      out.size.push_back(int(size[r]));
      out.mean_colour.push_back(mean(r));
    }
    out.label[i] = id_of_root[r];
  }
  return out;
}

Patches segment_patches(const tiles::Raster& image, const SegmentationOptions& options) {
  return merge_patches(segment_graph(image, options), options);
}

}  // namespace zoomwarp::warp
