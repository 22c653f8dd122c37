// method=mp's precomputation (methods/mp/mp_precompute.h) and its mesh (meshing/constrained_mesh.h):
// the mesh tiles the rectangle with the border and the line chains as edges, objects are
// vertex-disjoint and where the saliency says, the object-length tables are the objects' masks,
// and the model's bytes round-trip exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <random>
#include <set>

#include "tests/support/analysed_image.h"
#include "tests/support/images.h"
#include "warp/meshing/constrained_mesh.h"
#include "warp/methods/mp/mp_precompute.h"
#include "warp/saliency/gbvs.h"

namespace zoomwarp {
namespace {

using warp::Point;
using warp::Segment;

double angle_at(const Point& a, const Point& b, const Point& c) {  // at a, degrees
  const double ux = b.x - a.x, uy = b.y - a.y, vx = c.x - a.x, vy = c.y - a.y;
  return std::acos(std::clamp((ux * vx + uy * vy) / std::hypot(ux, uy) / std::hypot(vx, vy), -1.0, 1.0)) * 180 / M_PI;
}

double min_angle(const warp::Mesh& m) {
  double lo = 180;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k)
      lo = std::min(lo, angle_at(m.vertices[t[k]], m.vertices[t[(k + 1) % 3]], m.vertices[t[(k + 2) % 3]]));
  return lo;
}

std::set<std::pair<int, int>> edges_of(const warp::Mesh& m) {
  std::set<std::pair<int, int>> e;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) e.insert(std::minmax(t[k], t[(k + 1) % 3]));
  return e;
}

// A valid mesh of [0, w] × [0, h]: every vertex inside, every triangle counter-clockwise, the
// areas summing to the rectangle's, and every edge used by one triangle only lying on the border
// (both ends on the same side).
void expect_tiles_rectangle(const warp::Mesh& m, double w, double h) {
  ASSERT_FALSE(m.triangles.empty());
  for (const Point& p : m.vertices) {
    EXPECT_GE(p.x, 0);
    EXPECT_LE(p.x, w);
    EXPECT_GE(p.y, 0);
    EXPECT_LE(p.y, h);
  }
  double area = 0;
  std::map<std::pair<int, int>, int> uses;
  for (const auto& t : m.triangles) {
    const double a = warp::signed_area2(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]);
    EXPECT_GT(a, 0) << "a triangle is not counter-clockwise";
    area += a / 2;
    for (int k = 0; k < 3; ++k) ++uses[std::minmax(t[k], t[(k + 1) % 3])];
  }
  EXPECT_NEAR(area, w * h, 1e-9 * w * h);
  for (const auto& [e, n] : uses) {
    EXPECT_LE(n, 2);
    if (n == 1) {
      const Point &a = m.vertices[e.first], &b = m.vertices[e.second];
      EXPECT_TRUE((a.x == 0 && b.x == 0) || (a.y == 0 && b.y == 0) || (a.x == w && b.x == w) || (a.y == h && b.y == h))
          << "an open edge off the border: (" << a.x << ", " << a.y << ") – (" << b.x << ", " << b.y << ")";
    }
  }
}

// Random points inside, a few on the border, and a zigzag chain of constraints.
struct MeshInput {
  std::vector<Point> points;
  std::vector<std::array<int, 2>> constraints;
};

MeshInput random_input(double w, double h, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(1, w - 1), y(1, h - 1);
  MeshInput in;
  in.points = {{0, 0}, {w / 2, 0}, {w, h / 3}, {w / 4, h}};
  for (int i = 0; i < 5; ++i) in.points.push_back({w * (0.1 + 0.15 * i), h * (i % 2 ? 0.4 : 0.6)});
  for (int i = 4; i < 8; ++i) in.constraints.push_back({i, i + 1});
  while (int(in.points.size()) < n) {
    const Point p{x(rng), y(rng)};
    // Near the chain, so that its edges are not Delaunay edges by themselves, but not on it.
    bool on_chain = false;
    for (const auto& [a, b] : in.constraints) {
      const Point &u = in.points[a], &v = in.points[b];
      const double t = std::clamp(((p.x - u.x) * (v.x - u.x) + (p.y - u.y) * (v.y - u.y)) /
                                      ((v.x - u.x) * (v.x - u.x) + (v.y - u.y) * (v.y - u.y)),
                                  0.0, 1.0);
      on_chain |= std::hypot(p.x - u.x - t * (v.x - u.x), p.y - u.y - t * (v.y - u.y)) < 2;
    }
    if (!on_chain) in.points.push_back(p);
  }
  return in;
}

TEST(MpMesh, TilesTheRectangleWithItsPointsAndConstraints) {
  const double w = 640, h = 360;
  const MeshInput in = random_input(w, h, 120, 7);
  warp::ConstrainedMeshOptions generous;
  generous.vertex_budget = 100000;
  const warp::Mesh m = warp::build_constrained_mesh(w, h, in.points, in.constraints, generous);
  expect_tiles_rectangle(m, w, h);
  for (std::size_t i = 0; i < in.points.size(); ++i) {
    EXPECT_EQ(m.vertices[i].x, in.points[i].x);
    EXPECT_EQ(m.vertices[i].y, in.points[i].y);
  }
  // Each constraint is an edge, or a chain of edges along it (refinement splits it).
  const auto edges = edges_of(m);
  for (const auto& [a, b] : in.constraints) {
    const auto chain = warp::vertices_on_segment(m, {in.points[a], in.points[b]});
    ASSERT_GE(chain.size(), 2u);
    EXPECT_EQ(chain.front(), a);
    EXPECT_EQ(chain.back(), b);
    for (std::size_t k = 1; k < chain.size(); ++k) EXPECT_TRUE(edges.count(std::minmax(chain[k - 1], chain[k])));
  }
  // Unbounded, refinement reaches the angle (no constraint meets another below 60°).
  EXPECT_GE(min_angle(m), 20 - 1e-9);
  const double unrefined = min_angle(warp::build_constrained_mesh(w, h, in.points, in.constraints, {20, 1}));
  std::printf("min angle: %.2f° unrefined, %.2f° refined (%zu → %zu vertices)\n", unrefined, min_angle(m),
              in.points.size(), m.vertices.size());
  EXPECT_LT(unrefined, 20);
}

TEST(MpMesh, StopsAtTheVertexBudget) {
  const double w = 640, h = 360;
  const MeshInput in = random_input(w, h, 120, 7);
  for (int budget : {130, 150}) {
    const warp::Mesh m = warp::build_constrained_mesh(w, h, in.points, in.constraints, {20, budget});
    expect_tiles_rectangle(m, w, h);
    EXPECT_LE(int(m.vertices.size()), budget);
    EXPECT_GE(int(m.vertices.size()), budget - 1);  // it did refine up to the budget
  }
}

TEST(MpMesh, RefusesDegenerateInput) {
  const double w = 100, h = 50;
  const std::vector<Point> p = {{10, 10}, {90, 40}, {10, 40}, {90, 10}, {50, 25}};
  const auto refused = [&](std::vector<Point> points, std::vector<std::array<int, 2>> c) {
    EXPECT_THROW(warp::build_constrained_mesh(w, h, points, c), std::invalid_argument);
  };
  auto dup = p;
  dup.push_back(p[2]);
  refused(dup, {});
  refused({{10, 10}, {101, 10}}, {});
  refused({{10, 10}, {NAN, 10}}, {});
  refused(p, {{0, 1}, {2, 3}});        // crossing at (50, 25)... which is point 4: still crossing
  refused(p, {{0, 1}, {4, 2}});        // point 4 lies on 0–1: touching away from a shared end
  refused(p, {{0, 4}, {0, 1}});        // overlapping from a shared end
  refused(p, {{0, 1}, {1, 0}});        // the same constraint twice
  refused(p, {{0, 5}});                // no point 5
  refused(p, {{3, 3}});                // one point twice
  refused({{0, 10}, {0, 40}}, {{0, 1}});  // along the border
  EXPECT_THROW(warp::build_constrained_mesh(0, h, {}, {}), std::invalid_argument);
  // Sharing an end is fine, and so is no point at all (the corners alone).
  expect_tiles_rectangle(warp::build_constrained_mesh(w, h, p, {{0, 4}, {4, 1}, {4, 2}}), w, h);
  expect_tiles_rectangle(warp::build_constrained_mesh(w, h, {}, {}), w, h);
}

// A MethodInput over owned data.
struct Input {
  warp::ImageModel model;
  tiles::Raster image;
  warp::SignificanceMap saliency;
  std::vector<Segment> detected;
  warp::Saliency kind = warp::Saliency::kDefault;

  Input(int wa, int ha, double scale = 1) : image(wa, ha, 3) {
    model.width = wa / scale;
    model.height = ha / scale;
    saliency.width = wa;
    saliency.height = ha;
    saliency.scale = scale;
    saliency.values.assign(std::size_t(wa) * ha, 0.f);
  }
  warp::MethodInput get() const { return {model, kind, saliency, image, model.lines, detected}; }
  // A disc of saliency 1 (map px) and a bright disc in the image.
  void disc(double cx, double cy, double r) {
    for (int y = 0; y < saliency.height; ++y)
      for (int x = 0; x < saliency.width; ++x)
        if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= r) {
          saliency.values[std::size_t(y) * saliency.width + x] = 1.f;
          std::fill_n(image.row(y) + 3 * x, 3, std::uint8_t(230));
        }
  }
  void rect(int x0, int y0, int x1, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) saliency.values[std::size_t(y) * saliency.width + x] = 1.f;
  }
};

void expect_valid_model(const warp::MpModel& m) {
  expect_tiles_rectangle(m.mesh, m.width, m.height);
  std::vector<int> owner(m.mesh.vertices.size(), -1);
  for (int o = 0; o < int(m.objects.size()); ++o)
    for (int v : m.objects[o].vertices) {
      EXPECT_EQ(owner[v], -1) << "vertex " << v << " is in objects " << owner[v] << " and " << o;
      owner[v] = o;
    }
  EXPECT_EQ(m.row_object_length.size(), std::size_t(std::lround(m.height)));
  EXPECT_EQ(m.column_object_length.size(), std::size_t(std::lround(m.width)));
  // Every line's points lie on its segment, in order along it, each written in a triangle holding
  // it (weights ≥ 0 up to rounding, summing to 1).
  for (const warp::MpLine& l : m.lines) {
    ASSERT_GE(l.points.size(), 2u);
    const Point a = position(l.points.front(), m.mesh.vertices), b = position(l.points.back(), m.mesh.vertices);
    ASSERT_GT(std::hypot(b.x - a.x, b.y - a.y), 0) << "two distinct ends";
    for (std::size_t k = 0; k < l.points.size(); ++k) {
      const warp::MpLinePoint& point = l.points[k];
      for (int i = 0; i < 3; ++i) {
        ASSERT_GE(point.vertices[i], 0);
        ASSERT_LT(point.vertices[i], int(m.mesh.vertices.size()));
        EXPECT_GE(point.weights[i], -1e-9);
      }
      EXPECT_NEAR(point.weights[0] + point.weights[1] + point.weights[2], 1, 1e-9);
      const Point p = position(point, m.mesh.vertices);
      EXPECT_LT(std::abs((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)) / std::hypot(b.x - a.x, b.y - a.y), 1e-6);
      if (k > 0) {
        const Point q = position(l.points[k - 1], m.mesh.vertices);
        EXPECT_GE((p.x - q.x) * (b.x - a.x) + (p.y - q.y) * (b.y - a.y), -1e-9) << "in order along the line, point " << k;
      }
    }
  }
}

TEST(MpPrecompute, OneDiscIsOneObjectWithItsPoleAtTheCentre) {
  Input in(800, 500);
  in.disc(300, 220, 90);
  const warp::MpModel m = warp::build_mp_model(in.get());
  expect_valid_model(m);
  ASSERT_EQ(m.objects.size(), 1u);
  const double d = std::sqrt(800.0 * 500 / 300);
  EXPECT_LT(std::hypot(m.objects[0].pole.x - 300, m.objects[0].pole.y - 220), d);
  // Triangles whose mean exceeds 0.6 lie mostly inside: the area is the disc's, give or take a
  // ring of triangles.
  EXPECT_NEAR(m.objects[0].area, M_PI * 90 * 90, 2 * M_PI * 90 * d);
  std::printf("disc: pole (%.1f, %.1f), area %.0f (disc %.0f), %zu vertices, d = %.1f\n", m.objects[0].pole.x,
              m.objects[0].pole.y, m.objects[0].area, M_PI * 90 * 90, m.mesh.vertices.size(), d);
}

TEST(MpPrecompute, GbvsDiscIsOneObjectWithItsPoleAtTheCentre) {
  Input in(640, 480);
  std::fill(in.image.pixels.begin(), in.image.pixels.end(), std::uint8_t(90));
  in.disc(400, 200, 70);
  in.saliency = warp::compute_gbvs(in.image, 640, 640, 480);
  in.kind = warp::Saliency::kGbvs;
  const warp::MpModel m = warp::build_mp_model(in.get());
  expect_valid_model(m);
  ASSERT_EQ(m.objects.size(), 1u);
  const double d = std::sqrt(640.0 * 480 / 300);
  EXPECT_LT(std::hypot(m.objects[0].pole.x - 400, m.objects[0].pole.y - 200), d);
}

TEST(MpPrecompute, ObjectsNeverShareAVertex) {
  Input in(800, 500);
  // Blobs close to each other: triangles between them may be salient too, and must join them.
  in.disc(200, 200, 60);
  in.disc(330, 200, 60);
  in.disc(600, 350, 70);
  in.rect(500, 60, 700, 130);
  const warp::MpModel m = warp::build_mp_model(in.get());
  expect_valid_model(m);
  EXPECT_GE(m.objects.size(), 2u);
  for (const warp::MpObject& o : m.objects) EXPECT_GE(o.vertices.size(), 3u);
  std::printf("%zu objects\n", m.objects.size());
}

TEST(MpPrecompute, AnObjectAcrossTheImageIsKept) {
  // A band from the left border to the right one, or from the top to the bottom: an object like
  // any other (issue 30: dropped, a façade spanning the width bent with the background); mp_solve
  // fixes its scale across the two borders.
  const auto touches = [](const warp::MpModel& m, auto on_border) {
    return std::any_of(m.objects[0].vertices.begin(), m.objects[0].vertices.end(),
                       [&](int v) { return on_border(m.mesh.vertices[v]); });
  };
  Input across(800, 500);
  across.rect(0, 200, 800, 300);
  const warp::MpModel wide = warp::build_mp_model(across.get());
  ASSERT_EQ(wide.objects.size(), 1u);
  EXPECT_TRUE(touches(wide, [](const Point& p) { return p.x == 0; }));
  EXPECT_TRUE(touches(wide, [](const Point& p) { return p.x == 800; }));
  Input down(800, 500);
  down.rect(300, 0, 400, 500);
  const warp::MpModel tall = warp::build_mp_model(down.get());
  ASSERT_EQ(tall.objects.size(), 1u);
  EXPECT_TRUE(touches(tall, [](const Point& p) { return p.y == 0; }));
  EXPECT_TRUE(touches(tall, [](const Point& p) { return p.y == 500; }));
}

TEST(MpPrecompute, SmallObjectsAreDropped) {
  // A disc of 1.3 % of the image: an object by default, dropped when objects must cover 2 %.
  Input in(800, 500);
  in.disc(400, 250, 40);
  ASSERT_EQ(warp::build_mp_model(in.get()).objects.size(), 1u);
  warp::MpPrecomputeOptions options;
  options.min_object_fraction = 0.02;
  EXPECT_TRUE(warp::build_mp_model(in.get(), options).objects.empty());
}

bool inside(const Point& a, const Point& b, const Point& c, const Point& q) {  // barycentric, edges in
  const double det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
  const double l1 = ((q.x - a.x) * (c.y - a.y) - (c.x - a.x) * (q.y - a.y)) / det;
  const double l2 = ((b.x - a.x) * (q.y - a.y) - (q.x - a.x) * (b.y - a.y)) / det;
  return l1 >= -1e-12 && l2 >= -1e-12 && l1 + l2 <= 1 + 1e-12;
}

TEST(MpPrecompute, TablesAreTheObjectMasks) {
  Input in(400, 300);
  in.disc(120, 120, 50);
  in.rect(250, 180, 360, 260);
  const warp::MpModel m = warp::build_mp_model(in.get());
  ASSERT_EQ(m.objects.size(), 2u);
  std::vector<double> rows(300, 0), cols(400, 0);
  double area = 0;
  for (const warp::MpObject& o : m.objects) {
    area += o.area;
    const std::set<int> vs(o.vertices.begin(), o.vertices.end());
    std::vector<warp::Triangle> faces;
    for (const auto& t : m.mesh.triangles)
      if (vs.count(t[0]) && vs.count(t[1]) && vs.count(t[2])) faces.push_back(t);
    for (int y = 0; y < 300; ++y)
      for (int x = 0; x < 400; ++x)
        for (const auto& t : faces)
          if (inside(m.mesh.vertices[t[0]], m.mesh.vertices[t[1]], m.mesh.vertices[t[2]], {x + 0.5, y + 0.5})) {
            ++rows[y], ++cols[x];
            break;
          }
  }
  // An object's region: every triangle whose corners are all its own (mp_precompute.h).
  double total = 0;
  for (int y = 0; y < 300; ++y) EXPECT_EQ(m.row_object_length[y], rows[y]) << "row " << y;
  for (int x = 0; x < 400; ++x) EXPECT_EQ(m.column_object_length[x], cols[x]) << "column " << x;
  for (double v : m.row_object_length) total += v;
  double column_total = 0;
  for (double v : m.column_object_length) column_total += v;
  EXPECT_EQ(total, column_total);
  EXPECT_NEAR(total, area, 0.02 * area);  // pixel centres against exact areas
}

TEST(MpPrecompute, LinesAreConstrainedChainsHeldWhole) {
  // Image px at half the analysis resolution: the lines must be scaled.
  Input in(800, 500, 0.5);
  in.model.lines = {{{100, 600}, {1500, 400}}};                        // the curator's
  in.detected = {{{200, -100}, {200, 900}}, {{300, 610}, {1400, 410}}};  // the second along the first
  const warp::MpModel m = warp::build_mp_model(in.get());
  expect_valid_model(m);
  // Every line is held over its whole segment clipped to the image (issue 30): the vertical one
  // from the top border, across the gap where its chain is cut back from the curator's; the
  // third, along the curator's, with no chain at all (nothing of it is clear of the curator's).
  ASSERT_EQ(m.lines.size(), 3u);
  const double d = std::sqrt(800.0 * 500 / 300);
  const auto edges = edges_of(m.mesh);
  const auto is_vertex = [](const warp::MpLinePoint& p) { return p.vertices[0] == p.vertices[1] && p.vertices[1] == p.vertices[2]; };
  int gaps = 0;
  std::vector<int> chain_points(m.lines.size(), 0);
  for (std::size_t l = 0; l < m.lines.size(); ++l) {
    const auto& points = m.lines[l].points;
    int previous = -1;  // the last mesh vertex of the line so far
    for (std::size_t k = 0; k < points.size(); ++k) {
      const Point p = position(points[k], m.mesh.vertices);
      if (k > 0) {
        const Point q = position(points[k - 1], m.mesh.vertices);
        EXPECT_LE(std::hypot(p.x - q.x, p.y - q.y), d / 4 + 1e-9) << "points every ≤ d/4, line " << l;
      }
      if (!is_vertex(points[k])) continue;
      ++chain_points[l];
      const int v = points[k].vertices[0];
      if (previous >= 0) {
        const Point q = m.mesh.vertices[previous];
        if (edges.count(std::minmax(previous, v))) {
          EXPECT_LE(std::hypot(p.x - q.x, p.y - q.y), d / 2 + 1e-9) << "chains' points every d/2 [Guo09 §3.2]";
        } else {
          ++gaps;
          EXPECT_GE(std::hypot(p.x - q.x, p.y - q.y), d) << "a gap is the crossing, d/2 clear on either side";
        }
      }
      previous = v;
    }
  }
  EXPECT_EQ(gaps, 1) << "one crossing";
  EXPECT_GT(chain_points[0], 0);
  EXPECT_GT(chain_points[1], 0);
  EXPECT_EQ(chain_points[2], 0) << "the third line is held by its samples alone";
  // The lines' ends: scaled to analysis px and clipped to the image, not inset.
  const auto expect_ends = [&](const warp::MpLine& l, Point a, Point b) {
    const Point p = position(l.points.front(), m.mesh.vertices), q = position(l.points.back(), m.mesh.vertices);
    EXPECT_NEAR(p.x, a.x, 1e-9);
    EXPECT_NEAR(p.y, a.y, 1e-9);
    EXPECT_NEAR(q.x, b.x, 1e-9);
    EXPECT_NEAR(q.y, b.y, 1e-9);
  };
  expect_ends(m.lines[0], {50, 300}, {750, 200});
  expect_ends(m.lines[1], {100, 0}, {100, 450});
  expect_ends(m.lines[2], {150, 305}, {700, 205});
}

TEST(MpPrecompute, DegenerateImagesGiveATinyValidMesh) {
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{2, 10000}, std::pair{10000, 2}, std::pair{3, 3}}) {
    Input in(w, h);
    std::fill(in.saliency.values.begin(), in.saliency.values.end(), 1.f);  // salient all over
    for (warp::Saliency kind : warp::kSaliencies) {
      in.kind = kind;
      const warp::MpModel m = warp::build_mp_model(in.get());
      SCOPED_TRACE(std::to_string(w) + "×" + std::to_string(h));
      expect_valid_model(m);
      EXPECT_LE(m.objects.size(), 1u);  // all of it salient: at most one object, on every border
    }
  }
  Input empty(0, 0);
  const warp::MpModel m = warp::build_mp_model(empty.get());
  EXPECT_TRUE(m.mesh.vertices.empty());
  EXPECT_EQ(warp::parse_mp_model(warp::mp_model_bytes(m)).mesh.vertices.size(), 0u);
}

TEST(MpModelBytes, RoundTripByteIdenticalAndDeterministic) {
  Input in(800, 500);
  in.disc(300, 220, 90);
  in.model.lines = {{{100, 300}, {700, 200}}};
  const std::string bytes = warp::mp_model_bytes(warp::build_mp_model(in.get()));
  EXPECT_EQ(warp::mp_model_bytes(warp::build_mp_model(in.get())), bytes);
  const warp::MpModel m = warp::parse_mp_model(bytes);
  EXPECT_EQ(warp::mp_model_bytes(m), bytes);
  ASSERT_EQ(m.objects.size(), 1u);
  ASSERT_EQ(m.lines.size(), 1u);

  EXPECT_THROW(warp::parse_mp_model(bytes.substr(0, bytes.size() - 1)), std::runtime_error);
  EXPECT_THROW(warp::parse_mp_model(bytes + "x"), std::runtime_error);
  EXPECT_THROW(warp::parse_mp_model(""), std::runtime_error);
  std::string bad = bytes;
  const std::size_t first_triangle = 16 + 4 + 16 * m.mesh.vertices.size() + 4;
  const std::int32_t out_of_range = std::int32_t(m.mesh.vertices.size());
  std::memcpy(bad.data() + first_triangle, &out_of_range, 4);
  EXPECT_THROW(warp::parse_mp_model(bad), std::runtime_error);
}

// The model drawn over the analysis image: object regions tinted, edges white, line chains red,
// poles blue. Written by the Samples test when ZOOMWARP_MP_FIGURES names a folder.
void write_figure(const std::string& path, const warp::MpModel& m, const tiles::Raster& analysis) {
  tiles::Raster r = testing::take_channels(analysis, 3);
  const auto paint = [&](int x, int y, std::array<std::uint8_t, 3> c, double alpha) {
    if (x < 0 || y < 0 || x >= r.width || y >= r.height) return;
    for (int k = 0; k < 3; ++k) r.row(y)[3 * x + k] = std::uint8_t((1 - alpha) * r.row(y)[3 * x + k] + alpha * c[k]);
  };
  const auto segment = [&](const Point& a, const Point& b, std::array<std::uint8_t, 3> c) {
    const int n = int(std::ceil(std::max(std::abs(b.x - a.x), std::abs(b.y - a.y)))) + 1;
    for (int i = 0; i <= n; ++i)
      paint(int(a.x + (b.x - a.x) * i / n), int(a.y + (b.y - a.y) * i / n), c, 1);
  };
  std::vector<int> owner(m.mesh.vertices.size(), -1);
  for (int o = 0; o < int(m.objects.size()); ++o)
    for (int v : m.objects[o].vertices) owner[v] = o;
  for (const auto& t : m.mesh.triangles) {
    const Point &a = m.mesh.vertices[t[0]], &b = m.mesh.vertices[t[1]], &c = m.mesh.vertices[t[2]];
    if (owner[t[0]] >= 0 && owner[t[0]] == owner[t[1]] && owner[t[0]] == owner[t[2]])
      for (int y = 0; y < r.height; ++y)
        for (int x = 0; x < r.width; ++x)
          if (std::min({a.x, b.x, c.x}) <= x + 0.5 && x + 0.5 <= std::max({a.x, b.x, c.x}) &&
              std::min({a.y, b.y, c.y}) <= y + 0.5 && y + 0.5 <= std::max({a.y, b.y, c.y}) && inside(a, b, c, {x + 0.5, y + 0.5}))
            paint(x, y, {255, 200, 0}, 0.45);
    for (int k = 0; k < 3; ++k) segment(m.mesh.vertices[t[k]], m.mesh.vertices[t[(k + 1) % 3]], {255, 255, 255});
  }
  for (const warp::MpLine& l : m.lines)
    for (std::size_t k = 1; k < l.points.size(); ++k)
      segment(position(l.points[k - 1], m.mesh.vertices), position(l.points[k], m.mesh.vertices), {255, 0, 0});
  for (const warp::MpObject& o : m.objects)
    for (int dy = -4; dy <= 4; ++dy)
      for (int dx = -4; dx <= 4; ++dx) paint(int(o.pole.x) + dx, int(o.pole.y) + dy, {0, 0, 255}, 1);
  testing::write_image(path, r);
}

// The samples, both saliency kinds, as ingest would see them: a valid model, its size and time.
TEST(MpPrecompute, Samples) {
  for (const char* file : {"boats_lake_sunset.jpg", "astronaut_portrait.png", "interior_wine_djembe_tall.jpg",
                           "pano_grossmugl_field_4to1.png"}) {
    const testing::AnalysedImage sample = testing::analyse_sample(file);
    const tiles::Raster& small = sample.analysis;
    for (warp::Saliency kind : warp::kSaliencies) {
      const warp::SignificanceMap map = sample.saliency(kind);
      const double f = map.scale;
      const auto t0 = std::chrono::steady_clock::now();
      const warp::MpModel m = warp::build_mp_model(sample.input(kind, map));
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      SCOPED_TRACE(file);
      expect_valid_model(m);
      if (const char* dir = std::getenv("ZOOMWARP_MP_FIGURES"))
        write_figure(std::string(dir) + "/" + file + "." + std::string(warp::saliency_name(kind)) + ".png", m, small);
      // The largest triangle mean: Sμ = 0.6 is on this scale.
      double top = 0;
      for (const auto& t : m.mesh.triangles)
        top = std::max(top, warp::mean_over_triangle(map, {m.mesh.vertices[t[0]].x / f, m.mesh.vertices[t[0]].y / f},
                                                     {m.mesh.vertices[t[1]].x / f, m.mesh.vertices[t[1]].y / f},
                                                     {m.mesh.vertices[t[2]].x / f, m.mesh.vertices[t[2]].y / f}));
      std::size_t chain = 0;
      for (const auto& l : m.lines) chain += l.points.size();
      std::printf("%-32s %-7s %4dx%-4d %4zu vertices %4zu triangles, min angle %5.2f°, %zu objects, %zu lines "
                  "(%zu vertices) of %zu detected, largest triangle mean %.2f, %.1f ms\n",
                  file, std::string(warp::saliency_name(kind)).c_str(), small.width, small.height,
                  m.mesh.vertices.size(), m.mesh.triangles.size(), min_angle(m.mesh), m.objects.size(), m.lines.size(),
                  chain, sample.detected.size(), top, ms);
    }
  }
}

}  // namespace
}  // namespace zoomwarp
