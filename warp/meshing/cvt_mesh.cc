// A CGAL translation unit (meshing/README.md, cgal_cdt.h): the Delaunay triangulation of the seeds
// and their mirror images, whose dual is the clipped Voronoi diagram.
#include "warp/meshing/cgal_cdt.h"
#include "warp/meshing/cvt_mesh.h"

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>

#include "warp/core/parallel_for.h"

namespace zoomwarp::warp {

namespace {

using cgal_cdt::K;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<int, K>;  // info: seed index, −1 for a mirror
// info: the face's Voronoi vertex in voronoi_cells (−1 before it is looked up)
using Fb = CGAL::Triangulation_face_base_with_info_2<int, K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Delaunay = CGAL::Delaunay_triangulation_2<K, Tds>;

[[noreturn]] void refuse(const std::string& why) { throw std::invalid_argument("cvt mesh: " + why); }

// ρ per map pixel (METHODS §3 step 2), row-major like the map.
cv::Mat density(const std::vector<float>& saliency, int map_w, int map_h, double pixel_size) {
  const cv::Mat s(map_h, map_w, CV_32F, const_cast<float*>(saliency.data()));
  cv::Mat dx, dy, magnitude;
  cv::Sobel(s, dx, CV_32F, 1, 0, 3, 1, 0, cv::BORDER_REPLICATE);
  cv::Sobel(s, dy, CV_32F, 0, 1, 3, 1, 0, cv::BORDER_REPLICATE);
  cv::magnitude(dx, dy, magnitude);
  double max_magnitude = 0;
  cv::minMaxLoc(magnitude, nullptr, &max_magnitude);
  if (max_magnitude <= 0) return cv::Mat(map_h, map_w, CV_32F, cv::Scalar(1));
  // distanceTransform measures the distance to the nearest zero pixel: edges are the zeros.
  const cv::Mat not_edge = magnitude < 0.1 * max_magnitude;
  cv::Mat d;
  cv::distanceTransform(not_edge, d, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  cv::Mat rho(map_h, map_w, CV_32F);
  for (int y = 0; y < map_h; ++y)
    for (int x = 0; x < map_w; ++x) {
      const double distance = std::max(1.0, d.at<float>(y, x) * pixel_size);
      rho.at<float>(y, x) = not_edge.at<unsigned char>(y, x) ? float(1 / (distance * distance * distance)) : 1.0f;
    }
  return rho;
}

double uniform(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }

// N points drawn from ρ, piecewise constant over map pixels covering the rectangle.
std::vector<Point> sample_seeds(const cv::Mat& rho, int n, double w, double h, unsigned long long seed) {
  std::vector<double> cumulative(rho.total());
  double sum = 0;
  for (int i = 0; i < int(rho.total()); ++i) cumulative[i] = sum += rho.at<float>(i / rho.cols, i % rho.cols);
  std::mt19937_64 rng(seed);
  std::vector<Point> seeds;
  seeds.reserve(n);
  while (int(seeds.size()) < n) {
    const auto i = std::upper_bound(cumulative.begin(), cumulative.end(), uniform(rng) * sum) - cumulative.begin();
    if (i >= int(cumulative.size())) continue;
    const double x = (int(i) % rho.cols + uniform(rng)) * w / rho.cols;
    const double y = (int(i) / rho.cols + uniform(rng)) * h / rho.rows;
    if (x > 0 && x < w && y > 0 && y < h) seeds.push_back({x, y});
  }
  return seeds;
}

// The seeds (info = index) and their images in the four sides (info = −1 − index).
Delaunay mirrored_triangulation(const std::vector<Point>& seeds, double w, double h) {
  std::vector<std::pair<K::Point_2, int>> points;
  for (int i = 0; i < int(seeds.size()); ++i) {
    const auto [x, y] = seeds[i];
    points.emplace_back(K::Point_2(x, y), i);
    points.emplace_back(K::Point_2(-x, y), -1 - i);
    points.emplace_back(K::Point_2(2 * w - x, y), -1 - i);
    points.emplace_back(K::Point_2(x, -y), -1 - i);
    points.emplace_back(K::Point_2(x, 2 * h - y), -1 - i);
  }
  Delaunay dt;
  dt.insert(points.begin(), points.end());
  return dt;
}

// The mirrored triangulation's dual restricted to the seeds' cells: the clipped Voronoi diagram.
PolygonMesh voronoi_cells(const std::vector<Point>& seeds, double w, double h) {
  Delaunay dt = mirrored_triangulation(seeds, w, h);
  for (auto f : dt.all_face_handles()) f->info() = -1;
  const double tolerance = 1e-9 * std::max(w, h);
  PolygonMesh mesh;
  mesh.width = w;
  mesh.height = h;
  mesh.cells.resize(seeds.size());
  // A circumcentre within `tolerance` of a vertex already made is that vertex (the first made):
  // cocircular seeds give one Voronoi vertex from several faces. Few hundred vertices: a linear
  // search is cheap enough, once per face (the face's info keeps the answer for its other
  // seeds, the one the search would give again: vertices are only ever appended).
  const auto vertex_of = [&](K::Point_2 c) {
    Point p{c.x(), c.y()};
    for (double* coordinate : {&p.x, &p.y}) {
      const double side = coordinate == &p.x ? w : h;
      if (std::abs(*coordinate) <= tolerance) *coordinate = 0;
      if (std::abs(*coordinate - side) <= tolerance) *coordinate = side;
    }
    for (int k = 0; k < int(mesh.vertices.size()); ++k)
      if (std::abs(mesh.vertices[k].x - p.x) <= tolerance && std::abs(mesh.vertices[k].y - p.y) <= tolerance) return k;
    mesh.vertices.push_back(p);
    return int(mesh.vertices.size()) - 1;
  };
  for (auto v : dt.finite_vertex_handles()) {
    if (v->info() < 0) continue;
    std::vector<int>& cell = mesh.cells[v->info()];
    // Faces around a vertex circulate counter-clockwise (positive orientation = mesh.h's sense).
    auto face = dt.incident_faces(v), end = face;
    do {
      if (dt.is_infinite(face)) throw std::logic_error("cvt mesh: a seed on the hull of its mirror images");
      if (face->info() < 0) face->info() = vertex_of(dt.circumcenter(face));
      const int k = face->info();
      if (cell.empty() || (cell.back() != k && cell.front() != k)) cell.push_back(k);
    } while (++face != end);
  }
  return mesh;
}

// Weighted Lloyd [PolyFEM eq. 9] on `rho` (already ≤ lloyd_side), in place. A pixel's label is
// the seed nearest its centre, i.e. the clipped Voronoi cell holding the centre: each cell is
// scan-converted, a centre on an edge going to the cell on its right (below, on a horizontal
// edge), with the edge's x computed alike from both sides, so every centre counts exactly once.
void lloyd(std::vector<Point>& seeds, const cv::Mat& rho, double w, double h, const CvtMeshOptions& options) {
  const int n = int(seeds.size());
  const double sx = w / rho.cols, sy = h / rho.rows;
  for (int iteration = 0; iteration < options.lloyd_iterations; ++iteration) {
    const PolygonMesh cells = voronoi_cells(seeds, w, h);
    // Each cell's centroid on its own (the cells in parallel), then the seeds moved in order.
    std::vector<std::optional<Point>> centroid(n);
    parallel_for(n, [&](int i) {
      const std::vector<int>& cell = cells.cells[i];
      double top = h, bottom = 0;
      for (int v : cell) {
        top = std::min(top, cells.vertices[v].y);
        bottom = std::max(bottom, cells.vertices[v].y);
      }
      double mass = 0, mx = 0, my = 0;
      // Rows whose centre y = (row + 0.5)·sy lies in [top, bottom).
      for (int row = std::max(0, int(std::ceil(top / sy - 0.5))); row < rho.rows && (row + 0.5) * sy < bottom; ++row) {
        const double y = (row + 0.5) * sy;
        double left = w, right = 0;
        for (std::size_t k = 0; k < cell.size(); ++k) {
          Point a = cells.vertices[cell[k]], b = cells.vertices[cell[(k + 1) % cell.size()]];
          if (a.y > b.y) std::swap(a, b);
          if (!(a.y <= y && y < b.y)) continue;
          const double x = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
          left = std::min(left, x);
          right = std::max(right, x);
        }
        const int first = std::max(0, int(std::ceil(left / sx - 0.5)));
        const int last = std::min(rho.cols, int(std::ceil(right / sx - 0.5)));  // exclusive
        for (int col = first; col < last; ++col) {
          const double m = rho.at<float>(row, col);
          mass += m;
          mx += m * (col + 0.5) * sx;
          my += m * y;
        }
      }
      if (mass > 0) centroid[i] = Point{mx / mass, my / mass};
    });
    double max_move = 0;
    for (int i = 0; i < n; ++i) {
      if (!centroid[i]) continue;
      const Point c = *centroid[i];
      max_move = std::max(max_move, std::hypot(c.x - seeds[i].x, c.y - seeds[i].y));
      seeds[i] = c;
    }
    if (max_move < 0.01) return;
  }
}

// Σ R(R − 2r) = Σ (abc)²/(16A²) − abc/(a + b + c) over the triangles with a seed among their
// corners; with `gradient`, its gradient with respect to the seeds (mirrors by the chain rule).
double edge_energy(const std::vector<Point>& seeds, double w, double h, std::vector<Point>* gradient) {
  const Delaunay dt = mirrored_triangulation(seeds, w, h);
  if (gradient) gradient->assign(seeds.size(), Point{});
  double energy = 0;
  for (auto f : dt.finite_face_handles()) {
    int info[3];
    Point p[3];
    for (int i = 0; i < 3; ++i) {
      info[i] = f->vertex(i)->info();
      p[i] = {f->vertex(i)->point().x(), f->vertex(i)->point().y()};
    }
    if (info[0] < 0 && info[1] < 0 && info[2] < 0) continue;
    // Edge i is opposite corner i.
    double length[3];
    Point unit[3];  // d length[i] / d p[i+1] (and −that for p[i+2])
    for (int i = 0; i < 3; ++i) {
      const Point &a = p[(i + 1) % 3], &b = p[(i + 2) % 3];
      length[i] = std::hypot(a.x - b.x, a.y - b.y);
      unit[i] = {(a.x - b.x) / length[i], (a.y - b.y) / length[i]};
    }
    const double area = 0.5 * signed_area2(p[0], p[1], p[2]);
    const double product = length[0] * length[1] * length[2], perimeter = length[0] + length[1] + length[2];
    energy += product * product / (16 * area * area) - product / perimeter;
    if (!gradient) continue;
    // ∂E/∂product, ∂E/∂area, ∂E/∂perimeter.
    const double e_product = product / (8 * area * area) - 1 / perimeter;
    const double e_area = -product * product / (8 * area * area * area);
    const double e_perimeter = product / (perimeter * perimeter);
    for (int i = 0; i < 3; ++i) {
      const Point &next = p[(i + 1) % 3], &prev = p[(i + 2) % 3];
      // Corner i touches edges i+1 and i+2; ∂(2A)/∂p_i = (y_{i+1} − y_{i+2}, x_{i+2} − x_{i+1}).
      const Point &u1 = unit[(i + 1) % 3], &u2 = unit[(i + 2) % 3];
      // Edge i+1 runs p[i+2] → p[i]: its length grows along −u1 at p[i]; edge i+2 along +u2.
      const double e1 = e_product * product / length[(i + 1) % 3] + e_perimeter;
      const double e2 = e_product * product / length[(i + 2) % 3] + e_perimeter;
      const Point g{-e1 * u1.x + e2 * u2.x + e_area * 0.5 * (next.y - prev.y),
                    -e1 * u1.y + e2 * u2.y + e_area * 0.5 * (prev.x - next.x)};
      const int s = info[i] >= 0 ? info[i] : -1 - info[i];
      const Point& seed = seeds[s];
      // A mirror in a vertical side flips x, in a horizontal side y.
      const bool flip_x = info[i] < 0 && p[i].x != seed.x, flip_y = info[i] < 0 && p[i].y != seed.y;
      (*gradient)[s].x += flip_x ? -g.x : g.x;
      (*gradient)[s].y += flip_y ? -g.y : g.y;
    }
  }
  return energy;
}

// Over the mesh's edges, each counted once (interior edges belong to two cells).
bool has_short_edge(const PolygonMesh& mesh, double ratio) {
  std::vector<double> lengths;
  for (const auto& cell : mesh.cells)
    for (std::size_t k = 0; k < cell.size(); ++k) {
      const int a = cell[k], b = cell[(k + 1) % cell.size()];
      const Point &p = mesh.vertices[a], &q = mesh.vertices[b];
      const bool border = (p.x == 0 && q.x == 0) || (p.y == 0 && q.y == 0) ||
                          (p.x == mesh.width && q.x == mesh.width) || (p.y == mesh.height && q.y == mesh.height);
      if (a < b || border) lengths.push_back(std::hypot(p.x - q.x, p.y - q.y));
    }
  double mean = 0;
  for (double l : lengths) mean += l / lengths.size();
  // In a rectangle thinner than the cells are long (a 2×10000 image: 1 px of analysis width) the
  // cells' short edges span the rectangle's width: that is the shortest any edge can be, so the
  // bound never asks for more than half of it (ours).
  const double bound = std::min(ratio * mean, 0.5 * std::min(mesh.width, mesh.height));
  return std::any_of(lengths.begin(), lengths.end(), [&](double l) { return l < bound; });
}

// Fails loudly on what a Voronoi diagram should never give but rounding could: a cell with fewer
// than three vertices (two seeds clamped onto one point) or a corner that does not turn left.
void check_cells(const PolygonMesh& mesh) {
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) {
    const std::vector<int>& cell = mesh.cells[c];
    bool convex = cell.size() >= 3;
    for (std::size_t k = 0; convex && k < cell.size(); ++k)
      convex = signed_area2(mesh.vertices[cell[k]], mesh.vertices[cell[(k + 1) % cell.size()]],
                            mesh.vertices[cell[(k + 2) % cell.size()]]) > 0;
    if (!convex) throw std::runtime_error("cvt mesh: cell " + std::to_string(c) + " is degenerate or not convex");
  }
}

}  // namespace

PolygonMesh build_cvt_mesh(const std::vector<float>& saliency, int map_w, int map_h, double width, double height,
                           const CvtMeshOptions& options) {
  if (!(std::isfinite(width) && std::isfinite(height) && width > 0 && height > 0))
    refuse("the rectangle must have a positive size");
  if (map_w < 1 || map_h < 1 || saliency.size() != std::size_t(map_w) * map_h)
    refuse("the saliency map must have map_w·map_h ≥ 1 values");
  if (!std::all_of(saliency.begin(), saliency.end(), [](float s) { return std::isfinite(s); }))
    refuse("the saliency map has a non-finite value");
  if (options.cells < 1) refuse("at least one cell is needed");

  const int n = int(std::clamp(std::floor(width * height / options.min_cell_area), 1.0, double(options.cells)));
  const cv::Mat rho = density(saliency, map_w, map_h, std::sqrt(width / map_w * height / map_h));
  std::vector<Point> seeds = sample_seeds(rho, n, width, height, options.seed);

  cv::Mat small = rho;
  if (std::max(map_w, map_h) > options.lloyd_side) {
    const double f = double(options.lloyd_side) / std::max(map_w, map_h);
    cv::resize(rho, small, cv::Size(std::max(1, int(std::lround(map_w * f))), std::max(1, int(std::lround(map_h * f)))),
               0, 0, cv::INTER_AREA);
  }
  lloyd(seeds, small, width, height, options);

  // Gradient descent with an adaptive step: one that raises E_se is halved and retried.
  const double spacing = std::sqrt(width * height / n);
  double step = 0;
  std::vector<Point> gradient;
  double energy = edge_energy(seeds, width, height, &gradient);
  for (int iteration = 0;; ++iteration) {
    PolygonMesh mesh = voronoi_cells(seeds, width, height);
    if (!has_short_edge(mesh, options.min_edge_ratio)) {
      check_cells(mesh);
      return mesh;
    }
    if (iteration == options.max_optimisation_steps)
      throw std::runtime_error("cvt mesh: " + std::to_string(options.max_optimisation_steps) +
                               " steps of [PolyFEM eq. 10] left an edge shorter than " +
                               std::to_string(options.min_edge_ratio) + " of the mean");
    double largest = 0;
    for (const Point& g : gradient) largest = std::max(largest, std::hypot(g.x, g.y));
    if (largest == 0) continue;
    if (step == 0) step = 0.05 * spacing / largest;
    // Seeds stay strictly inside, so that none meets its own mirror image.
    const double margin = 1e-3 * std::min({spacing, width, height});
    for (int attempt = 0; attempt < 30; ++attempt, step *= 0.5) {
      std::vector<Point> moved = seeds;
      for (std::size_t i = 0; i < moved.size(); ++i) {
        moved[i].x = std::clamp(moved[i].x - step * gradient[i].x, margin, width - margin);
        moved[i].y = std::clamp(moved[i].y - step * gradient[i].y, margin, height - margin);
      }
      std::vector<Point> moved_gradient;
      const double moved_energy = edge_energy(moved, width, height, &moved_gradient);
      if (moved_energy < energy) {
        seeds = std::move(moved);
        gradient = std::move(moved_gradient);
        energy = moved_energy;
        step *= 1.5;
        break;
      }
    }
  }
}

}  // namespace zoomwarp::warp
