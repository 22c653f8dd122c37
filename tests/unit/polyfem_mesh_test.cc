// method=polyfem's saliency-adaptive polygonal mesh (warp/meshing/cvt_mesh.h) [PolyFEM §4.3.2]: on
// a real sample's saliency, the cell count, convex counter-clockwise cells tiling the rectangle,
// conforming edges, no edge shorter than 5 % of the mean [§4.3.2], 003's DOF count, determinism
// and smaller cells along the saliency's edges; tiny and thin rectangles; refused input.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <stdexcept>
#include <utility>
#include <vector>

#include "tests/support/analysed_image.h"
#include "warp/meshing/cvt_mesh.h"
#include "warp/saliency/significance.h"

namespace zoomwarp {
namespace {

using warp::Point;
using warp::PolygonMesh;

double distance(const Point& a, const Point& b) { return std::hypot(a.x - b.x, a.y - b.y); }

bool on_one_side(const Point& a, const Point& b, double w, double h) {
  return (a.x == 0 && b.x == 0) || (a.y == 0 && b.y == 0) || (a.x == w && b.x == w) || (a.y == h && b.y == h);
}

double cell_area(const PolygonMesh& mesh, const std::vector<int>& cell) {
  double twice = 0;
  for (std::size_t k = 0; k < cell.size(); ++k) {
    const Point &a = mesh.vertices[cell[k]], &b = mesh.vertices[cell[(k + 1) % cell.size()]];
    twice += a.x * b.y - a.y * b.x;
  }
  return twice / 2;
}

Point cell_centroid(const PolygonMesh& mesh, const std::vector<int>& cell) {
  Point c;
  for (int v : cell) c = {c.x + mesh.vertices[v].x / cell.size(), c.y + mesh.vertices[v].y / cell.size()};
  return c;
}

// Each undirected edge once, as (smaller index, larger index) → the number of cells using it.
std::map<std::pair<int, int>, int> edges(const PolygonMesh& mesh) {
  std::map<std::pair<int, int>, int> count;
  for (const auto& cell : mesh.cells)
    for (std::size_t k = 0; k < cell.size(); ++k) {
      const int a = cell[k], b = cell[(k + 1) % cell.size()];
      ++count[{std::min(a, b), std::max(a, b)}];
    }
  return count;
}

std::vector<double> edge_lengths(const PolygonMesh& mesh) {
  std::vector<double> lengths;
  for (const auto& [edge, cells] : edges(mesh)) lengths.push_back(distance(mesh.vertices[edge.first], mesh.vertices[edge.second]));
  return lengths;
}

// Everything cvt_mesh.h promises of any mesh, the edge-length bound aside.
void expect_valid(const PolygonMesh& mesh, double w, double h) {
  EXPECT_EQ(mesh.width, w);
  EXPECT_EQ(mesh.height, h);
  ASSERT_FALSE(mesh.cells.empty());
  for (const Point& v : mesh.vertices) {
    EXPECT_TRUE(v.x >= 0 && v.x <= w && v.y >= 0 && v.y <= h) << v.x << ", " << v.y;
  }
  for (const Point corner : {Point{0, 0}, Point{w, 0}, Point{w, h}, Point{0, h}})
    EXPECT_TRUE(std::any_of(mesh.vertices.begin(), mesh.vertices.end(),
                            [&](const Point& v) { return v.x == corner.x && v.y == corner.y; }))
        << "corner " << corner.x << ", " << corner.y;

  // Strictly convex and counter-clockwise in mesh.h's sense: every corner turns the same way,
  // by more than rounding (so no three consecutive vertices are collinear).
  double area = 0;
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) {
    const auto& cell = mesh.cells[c];
    ASSERT_GE(cell.size(), 3u) << "cell " << c;
    const std::size_t n = cell.size();
    for (std::size_t k = 0; k < n; ++k) {
      const Point &a = mesh.vertices[cell[k]], &b = mesh.vertices[cell[(k + 1) % n]],
                  &d = mesh.vertices[cell[(k + 2) % n]];
      EXPECT_GT(warp::signed_area2(a, b, d), 1e-9 * distance(a, b) * distance(b, d)) << "cell " << c << " corner " << k;
    }
    area += cell_area(mesh, cell);
  }
  EXPECT_NEAR(area, w * h, 1e-9 * w * h);

  // Conforming: an interior edge is shared by exactly two cells (in opposite directions, which the
  // orientation check above implies), a border edge lies on one side; no vertex lies inside
  // another cell's edge.
  for (const auto& [edge, cells] : edges(mesh)) {
    const Point &a = mesh.vertices[edge.first], &b = mesh.vertices[edge.second];
    if (on_one_side(a, b, w, h))
      EXPECT_EQ(cells, 1) << "border edge " << edge.first << "–" << edge.second;
    else
      EXPECT_EQ(cells, 2) << "interior edge " << edge.first << "–" << edge.second;
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      if (int(v) == edge.first || int(v) == edge.second) continue;
      const Point& p = mesh.vertices[v];
      const double along = (p.x - a.x) * (b.x - a.x) + (p.y - a.y) * (b.y - a.y), length = distance(a, b);
      if (along <= 0 || along >= length * length) continue;
      EXPECT_GT(std::abs(warp::signed_area2(a, b, p)) / length, 1e-9 * std::max(w, h))
          << "vertex " << v << " on edge " << edge.first << "–" << edge.second;
    }
  }
}

// A Sobel edge mask of the map as cvt_mesh.h defines it (magnitude ≥ 0.1·max), replicated border.
std::vector<bool> saliency_edges(const warp::SignificanceMap& map) {
  const auto at = [&](int x, int y) {
    return double(map.at(std::clamp(x, 0, map.width - 1), std::clamp(y, 0, map.height - 1)));
  };
  std::vector<double> magnitude(map.values.size());
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x) {
      const double gx = at(x + 1, y - 1) + 2 * at(x + 1, y) + at(x + 1, y + 1) - at(x - 1, y - 1) - 2 * at(x - 1, y) -
                        at(x - 1, y + 1);
      const double gy = at(x - 1, y + 1) + 2 * at(x, y + 1) + at(x + 1, y + 1) - at(x - 1, y - 1) - 2 * at(x, y - 1) -
                        at(x + 1, y - 1);
      magnitude[std::size_t(y) * map.width + x] = std::hypot(gx, gy);
    }
  const double max = *std::max_element(magnitude.begin(), magnitude.end());
  std::vector<bool> edge(magnitude.size());
  for (std::size_t i = 0; i < magnitude.size(); ++i) edge[i] = magnitude[i] >= 0.1 * max;
  return edge;
}

class PolyfemMesh : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    map_ = new warp::SignificanceMap(testing::analyse_sample("boats_lake_sunset.jpg").saliency(warp::Saliency::kDefault));
    const auto start = std::chrono::steady_clock::now();
    mesh_ = new PolygonMesh(warp::build_cvt_mesh(map_->values, map_->width, map_->height, map_->width, map_->height));
    seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  static void TearDownTestSuite() {
    delete mesh_;
    delete map_;
  }
  static double w() { return map_->width; }
  static double h() { return map_->height; }

  static warp::SignificanceMap* map_;
  static PolygonMesh* mesh_;
  static double seconds_;
};

warp::SignificanceMap* PolyfemMesh::map_ = nullptr;
PolygonMesh* PolyfemMesh::mesh_ = nullptr;
double PolyfemMesh::seconds_ = 0;

TEST_F(PolyfemMesh, SampleHasAboutNConvexConformingCells) {
  RecordProperty("seconds", std::to_string(seconds_));
  RecordProperty("cells", int(mesh_->cells.size()));
  EXPECT_NEAR(double(mesh_->cells.size()), 200, 0.05 * 200);
  expect_valid(*mesh_, w(), h());
}

TEST_F(PolyfemMesh, NoEdgeShorterThanFivePercentOfTheMean) {
  const std::vector<double> lengths = edge_lengths(*mesh_);
  double mean = 0;
  for (double l : lengths) mean += l / lengths.size();
  EXPECT_GE(*std::min_element(lengths.begin(), lengths.end()), 0.05 * mean);
}

// Two DOFs per vertex and per edge midpoint: [PolyFEM Fig. 6] has 200 elements and 1,900 DOFs,
// [Fig. 9] 50 elements and about 460.
TEST_F(PolyfemMesh, DofsNear003sFigures) {
  const int dofs = 2 * int(mesh_->vertices.size() + edges(*mesh_).size());
  RecordProperty("dofs", dofs);
  EXPECT_NEAR(dofs, 1900, 0.15 * 1900);

  warp::CvtMeshOptions fifty;
  fifty.cells = 50;
  const PolygonMesh coarse = warp::build_cvt_mesh(map_->values, map_->width, map_->height, w(), h(), fifty);
  const int coarse_dofs = 2 * int(coarse.vertices.size() + edges(coarse).size());
  RecordProperty("dofs_50", coarse_dofs);
  EXPECT_NEAR(coarse_dofs, 460, 0.15 * 460);
}

TEST_F(PolyfemMesh, Deterministic) {
  const PolygonMesh again = warp::build_cvt_mesh(map_->values, map_->width, map_->height, w(), h());
  ASSERT_EQ(again.vertices.size(), mesh_->vertices.size());
  for (std::size_t v = 0; v < again.vertices.size(); ++v) {
    EXPECT_EQ(again.vertices[v].x, mesh_->vertices[v].x);
    EXPECT_EQ(again.vertices[v].y, mesh_->vertices[v].y);
  }
  EXPECT_EQ(again.cells, mesh_->cells);
}

// ρ is largest on the saliency's edges, so cells whose centroid lies near an edge pixel are smaller:
// on this sample by a factor of about 4 (with ρ = 1 both means are within 2 %).
TEST_F(PolyfemMesh, SmallerCellsAlongSaliencyEdges) {
  const std::vector<bool> edge = saliency_edges(*map_);
  const double reach = 0.25 * std::sqrt(w() * h() / 200);
  double near_area = 0, far_area = 0;
  int near_count = 0, far_count = 0;
  for (const auto& cell : mesh_->cells) {
    const Point c = cell_centroid(*mesh_, cell);
    bool near = false;
    for (int y = std::max(0, int(c.y - reach)); y <= std::min(map_->height - 1, int(c.y + reach)) && !near; ++y)
      for (int x = std::max(0, int(c.x - reach)); x <= std::min(map_->width - 1, int(c.x + reach)) && !near; ++x)
        near = edge[std::size_t(y) * map_->width + x] && std::hypot(x + 0.5 - c.x, y + 0.5 - c.y) <= reach;
    (near ? near_area : far_area) += cell_area(*mesh_, cell);
    ++(near ? near_count : far_count);
  }
  ASSERT_GT(near_count, 0);
  ASSERT_GT(far_count, 0);
  EXPECT_LT(near_area / near_count, 0.5 * far_area / far_count);
}

TEST_F(PolyfemMesh, TooFewStepsFailLoudly) {
  warp::CvtMeshOptions options;
  options.max_optimisation_steps = 0;
  EXPECT_THROW(warp::build_cvt_mesh(map_->values, map_->width, map_->height, w(), h(), options), std::runtime_error);
}

// No saliency edge: ρ = 1, a uniform CVT.
TEST(PolyfemMeshShapes, UniformSaliency) {
  const std::vector<float> flat(64 * 48, 0.5f);
  const PolygonMesh mesh = warp::build_cvt_mesh(flat, 64, 48, 640, 480);
  EXPECT_NEAR(double(mesh.cells.size()), 200, 10);
  expect_valid(mesh, 640, 480);
}

// Four cells on a uniform 16×16 square: Lloyd puts the seeds on a 2×2 grid, exactly co-circular.
// Their Delaunay triangles' equal circumcentres become one vertex shared by the four cells, not a
// zero-length edge.
TEST(PolyfemMeshShapes, CoCircularSeedsShareOneVertex) {
  const std::vector<float> flat(16 * 16, 0.5f);
  const PolygonMesh mesh = warp::build_cvt_mesh(flat, 16, 16, 16, 16);
  ASSERT_EQ(mesh.cells.size(), 4u);
  EXPECT_EQ(mesh.vertices.size(), 9u);
  expect_valid(mesh, 16, 16);
}

// N is capped at area/64 px², at least one cell: a 1×1 rectangle is one cell, the rectangle.
TEST(PolyfemMeshShapes, TinyRectangleIsOneCell) {
  const PolygonMesh mesh = warp::build_cvt_mesh({0.3f}, 1, 1, 1, 1);
  ASSERT_EQ(mesh.cells.size(), 1u);
  EXPECT_EQ(mesh.cells[0].size(), 4u);
  expect_valid(mesh, 1, 1);
}

TEST(PolyfemMeshShapes, ThinRectangle) {
  std::vector<float> map(2 * 1000);
  for (int y = 0; y < 1000; ++y) map[2 * y] = map[2 * y + 1] = y < 500 ? 0.2f : 0.9f;
  for (const auto& [w, h] : {std::pair{2.0, 1000.0}, std::pair{1000.0, 2.0}}) {
    const PolygonMesh mesh = w < h ? warp::build_cvt_mesh(map, 2, 1000, w, h) : warp::build_cvt_mesh(map, 1000, 2, w, h);
    EXPECT_EQ(mesh.cells.size(), 31u);  // floor(2000 / 64)
    expect_valid(mesh, w, h);
  }
}

TEST(PolyfemMeshShapes, RefusesBadInput) {
  const std::vector<float> map(4, 0.5f);
  EXPECT_THROW(warp::build_cvt_mesh(map, 2, 2, 0, 10), std::invalid_argument);
  EXPECT_THROW(warp::build_cvt_mesh(map, 2, 2, 10, NAN), std::invalid_argument);
  EXPECT_THROW(warp::build_cvt_mesh(map, 3, 2, 10, 10), std::invalid_argument);
  EXPECT_THROW(warp::build_cvt_mesh({0.5f, NAN, 0.5f, 0.5f}, 2, 2, 10, 10), std::invalid_argument);
}

}  // namespace
}  // namespace zoomwarp
