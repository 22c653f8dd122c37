// The precomputed mesh methods over the wire, method=mp [Guo09], method=patch [Lin13] and
// method=polyfem [PolyFEM]: ingest precomputes <method>.default.bin and <method>.gbvs.bin;
// /viewport is exactly w×h at every zoom and, on a screen of the image's aspect, zoom 1 is the
// IIIF crop; /mesh has ICAZ's shape and at zoom 0 spans the whole screen without a fold-over.
// mp: a curator's line becomes a chain of mesh vertices that stays straight on the screen; a
// significance edit marking a region as important makes it one rigid object (a similarity, no
// rotation), which it was not before. patch: a significance edit writes the new version's patch
// files and changes its warp. polyfem: a significance edit writes its files, moves the warp and
// distorts the marked region less.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <utility>
#include <vector>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HttpClient;

// A /mesh vertex: source (u, v) in image pixels, screen (x, y).
struct MeshVertex {
  double u, v, x, y;
};

std::vector<MeshVertex> vertices_of(const json& mesh) {
  std::vector<MeshVertex> out;
  for (const json& v : mesh["vertices"]) out.push_back({v[0], v[1], v[2], v[3]});
  return out;
}

// The best similarity screen ≈ a·source + t over `vs` (complex a): its residual, RMS over
// |a|·(RMS radius) — dimensionless, 0 for a rigid object [Guo09 eq. 3] — and its rotation.
struct SimilarityFit {
  double residual = 0, rotation = 0;
};
SimilarityFit similarity_fit(const std::vector<MeshVertex>& vs) {
  using C = std::complex<double>;
  C pm, qm;
  for (const MeshVertex& m : vs) pm += C(m.u, m.v), qm += C(m.x, m.y);
  pm /= double(vs.size());
  qm /= double(vs.size());
  C num;
  double den = 0;
  for (const MeshVertex& m : vs) {
    num += std::conj(C(m.u, m.v) - pm) * (C(m.x, m.y) - qm);
    den += std::norm(C(m.u, m.v) - pm);
  }
  const C a = num / den;
  double r2 = 0;
  for (const MeshVertex& m : vs) r2 += std::norm(C(m.x, m.y) - qm - a * (C(m.u, m.v) - pm));
  return {std::sqrt(r2 / den) / std::abs(a), std::arg(a)};
}

// The methods every test below runs for.
const char* const kMethods[] = {"mp", "patch", "polyfem"};

// The largest screen-position difference between two meshes of the same vertices.
double max_screen_shift(const std::vector<MeshVertex>& a, const std::vector<MeshVertex>& b) {
  double d = 0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) d = std::max(d, std::hypot(a[i].x - b[i].x, a[i].y - b[i].y));
  return a.size() == b.size() ? d : 1e9;
}

// Where image point (u, v) lands on the screen in `mesh`: interpolated in the triangle whose
// source contains it (NaN outside every triangle).
std::pair<double, double> screen_position(const json& mesh, double u, double v) {
  const std::vector<MeshVertex> vs = vertices_of(mesh);
  for (const json& t : mesh["triangles"]) {
    const MeshVertex &a = vs[t[0]], &b = vs[t[1]], &c = vs[t[2]];
    const double det = (b.u - a.u) * (c.v - a.v) - (b.v - a.v) * (c.u - a.u);
    const double l1 = ((u - a.u) * (c.v - a.v) - (v - a.v) * (c.u - a.u)) / det;
    const double l2 = ((b.u - a.u) * (v - a.v) - (b.v - a.v) * (u - a.u)) / det;
    if (l1 >= -1e-9 && l2 >= -1e-9 && l1 + l2 <= 1 + 1e-9)
      return {a.x + l1 * (b.x - a.x) + l2 * (c.x - a.x), a.y + l1 * (b.y - a.y) + l2 * (c.y - a.y)};
  }
  return {std::nan(""), std::nan("")};
}

class MeshMethods : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    file_ = new std::string(dir_->path() + "/boats.png");
    testing::write_image(*file_, testing::resize(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"),
                                                 1280, 800));
    const auto ingest =
        testing::run_command({testing::zoomwarp_binary(), "ingest", *file_, "--store", store(), "--id", "boats",
                              "--analyses", "all"});
    ingest_output_ = new std::string(ingest.output);
    ASSERT_EQ(ingest.exit_code, 0) << ingest.output;
    // Eager analyses (--analyses all): some tests are about the stored files an edit rewrites.
    server_ = new testing::ServerProcess(store(), {"--analyses", "all"});
  }
  static void TearDownTestSuite() {
    delete server_;
    delete ingest_output_;
    delete file_;
    delete dir_;
  }
  static std::string store() { return dir_->path() + "/store"; }

  // Uploads the boats again under `id` (a version of its own to edit).
  void upload(const std::string& id) {
    auto r = http.request("POST", "/v1/images?id=" + id, testing::read_file(*file_));
    ASSERT_EQ(r.status, 201) << r.body;
  }

  json mesh(const std::string& id, const std::string& query, const std::string& method = "mp") {
    auto r = http.get("/v1/images/" + id + "/mesh?method=" + method + "&" + query);
    EXPECT_EQ(r.status, 200) << query << ": " << r.body;
    return r.status == 200 ? json::parse(r.body) : json();
  }

  tiles::Raster image(const std::string& target) {
    auto r = http.get(target);
    EXPECT_EQ(r.status, 200) << target << ": " << r.body;
    return r.status == 200 ? testing::decode_image(r.body) : tiles::Raster();
  }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
  static std::string* file_;
  static std::string* ingest_output_;
};
testing::TempDir* MeshMethods::dir_ = nullptr;
testing::ServerProcess* MeshMethods::server_ = nullptr;
std::string* MeshMethods::file_ = nullptr;
std::string* MeshMethods::ingest_output_ = nullptr;

TEST_F(MeshMethods, IngestPrecomputesBothSaliencyKindsAndSaysHowLong) {
  const std::string dir = fs::canonical(store() + "/images/boats").string();
  for (const char* method : kMethods)
    for (const char* kind : {"default", "gbvs"}) {
      const std::string file = std::string(method) + "." + kind + ".bin";
      EXPECT_TRUE(fs::exists(dir + "/" + file)) << file;
      EXPECT_NE(ingest_output_->find(file + " "), std::string::npos) << *ingest_output_;
    }
}

TEST_F(MeshMethods, ViewportIsExactlyTheScreenAtEveryZoomAndTheCropAtZoomOne) {
  for (const std::string method : kMethods) {
    for (const char* saliency : {"default", "gbvs"})
      for (auto [w, h] : {std::pair{360, 640}, {640, 360}, {400, 400}, {960, 320}})
        for (const char* zoom : {"0", "0.5", "1"}) {
          const std::string q = "/v1/images/boats/viewport?method=" + method + "&format=png&saliency=" + saliency +
                                "&zoom=" + zoom + "&w=" + std::to_string(w) + "&h=" + std::to_string(h);
          const tiles::Raster v = image(q);
          EXPECT_EQ(v.width, w) << q;
          EXPECT_EQ(v.height, h) << q;
        }
    // 480 × 300 is the image's 16:10: the warp is the identity, zoom 1 the plain crop around (640, 400).
    const tiles::Raster crop =
        image("/v1/images/boats/viewport?method=" + method + "&zoom=1&cx=640&cy=400&w=480&h=300&format=png");
    const tiles::Raster iiif = image("/iiif/3/boats/400,250,480,300/max/0/default.png");
    EXPECT_EQ(testing::psnr(crop, iiif), std::numeric_limits<double>::infinity()) << method;
  }
}

// The JSON a thin client texture-maps: ICAZ's keys, every triangle at zoom 0, counter-clockwise.
// fit=warp covers the screen exactly (the boundary on the target rectangle, scaled to the
// screen); fit=auto (the default, issue 41) covers it and may reach past it along one axis (the
// crop): the boundary on the screen's edges across that axis, beyond them along it.
TEST_F(MeshMethods, MeshHasIcazsShapeAndCoversTheScreenWithoutFoldOvers) {
  const json icaz = json::parse(http.get("/v1/images/boats/mesh?method=icaz&zoom=0&w=360&h=640").body);
  std::set<std::string> icaz_keys;
  for (const auto& [k, v] : icaz.items()) icaz_keys.insert(k);
  for (const std::string fit : {"auto", "warp"})
  for (const std::string method : kMethods)
    for (auto [w, h] : {std::pair{360, 640}, {640, 360}, {960, 320}}) {
      SCOPED_TRACE(method + " " + std::to_string(w) + "x" + std::to_string(h) + " fit=" + fit);
      const json m = mesh("boats", "zoom=0&w=" + std::to_string(w) + "&h=" + std::to_string(h) + "&fit=" + fit, method);
      std::set<std::string> keys;
      for (const auto& [k, v] : m.items()) keys.insert(k);
      EXPECT_EQ(keys, icaz_keys);
      EXPECT_EQ(m["view"]["method"], method);
      const std::vector<MeshVertex> vs = vertices_of(m);
      ASSERT_GT(vs.size(), 100u) << "a few hundred feature points [Guo09 §3.2], a 20-px grid [Lin13 §IV], ~200 sampled cells";
      double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
      for (const MeshVertex& v : vs) x0 = std::min(x0, v.x), x1 = std::max(x1, v.x), y0 = std::min(y0, v.y), y1 = std::max(y1, v.y);
      double area = 0;
      for (const json& t : m["triangles"]) {
        const MeshVertex &a = vs[t[0]], &b = vs[t[1]], &c = vs[t[2]];
        const double a2 = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        EXPECT_GT(a2, 0) << "fold-over at (" << a.u << ", " << a.v << ")";
        area += a2 / 2;
      }
      // The boats are 16:10: 640×360 is within the budget (warped whole, as warp), the other two
      // crop along x (9:16) and along y (3:1).
      const bool crops_x = fit == "auto" && w == 360, crops_y = fit == "auto" && w == 960;
      // A crop covers the screen and reaches past it on one side at least (both, unless the
      // window is at the image's border).
      if (crops_x) {
        EXPECT_TRUE(x0 <= 0.002 && x1 >= w - 0.002 && (x0 < -1 || x1 > w + 1)) << x0 << " " << x1;
      } else {
        EXPECT_NEAR(x0, 0, 0.002);
        EXPECT_NEAR(x1, w, 0.002);
      }
      if (crops_y) {
        EXPECT_TRUE(y0 <= 0.002 && y1 >= h - 0.002 && (y0 < -1 || y1 > h + 1)) << y0 << " " << y1;
      } else {
        EXPECT_NEAR(y0, 0, 0.002);
        EXPECT_NEAR(y1, h, 0.002);
      }
      if (crops_x || crops_y) EXPECT_GT(area, double(w) * h + 1) << "the screen covered, and more";
      else EXPECT_NEAR(area, double(w) * h, 1) << "every triangle listed, the screen covered once";
    }
}

// A curator's line from (150, 560) to (1130, 700): after the PUT it is a chain of mesh vertices
// (every ~d/2 [Guo09 §3.3.3]) whose screen positions lie on one line within 1 px.
TEST_F(MeshMethods, MpMakesACuratorLineAChainOfVerticesKeptStraight) {
  upload("lined");
  const double ax = 150, ay = 560, bx = 1130, by = 700;
  const auto on_line = [&](const std::vector<MeshVertex>& vs) {
    std::vector<MeshVertex> out;
    const double len = std::hypot(bx - ax, by - ay);
    for (const MeshVertex& v : vs) {
      const double t = ((v.u - ax) * (bx - ax) + (v.v - ay) * (by - ay)) / (len * len);
      if (t >= 0 && t <= 1 && std::abs((bx - ax) * (v.v - ay) - (by - ay) * (v.u - ax)) / len < 0.05) out.push_back(v);
    }
    return out;
  };
  const std::string view = "zoom=0&w=360&h=640";
  EXPECT_LT(on_line(vertices_of(mesh("lined", view))).size(), 3u) << "the line is not in the mesh before the PUT";
  const json lines = {{"lines", {{ax, ay, bx, by}}}};
  auto r = http.request("PUT", "/v1/images/lined/lines", lines.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  for (const std::string screen : {"w=360&h=640", "w=960&h=320"}) {
    const std::vector<MeshVertex> chain = on_line(vertices_of(mesh("lined", "zoom=0&" + screen)));
    ASSERT_GE(chain.size(), 10u) << screen;
    const MeshVertex* first = &chain[0];
    const MeshVertex* last = &chain[0];
    for (const MeshVertex& v : chain) {
      if (v.u < first->u) first = &v;
      if (v.u > last->u) last = &v;
    }
    const double len = std::hypot(last->x - first->x, last->y - first->y);
    double bend = 0;
    for (const MeshVertex& v : chain)
      bend = std::max(bend, std::abs((last->x - first->x) * (v.y - first->y) - (last->y - first->y) * (v.x - first->x)) / len);
    std::printf("[ figures ] curator line on %s: %zu vertices, %.3f px from straight\n", screen.c_str(), chain.size(), bend);
    EXPECT_LT(bend, 1) << screen;
  }
}

// The sky from (120, 60) to (520, 300), marked as important (weight 1): its vertices then move
// by one similarity without rotation — a rigid object [Guo09 eq. 3] — where before the edit the
// stretch distorted them.
TEST_F(MeshMethods, MpMakesARegionMarkedImportantARigidObject) {
  upload("marked");
  const auto inside = [](const std::vector<MeshVertex>& vs) {
    std::vector<MeshVertex> out;
    for (const MeshVertex& v : vs)  // a margin of one feature spacing (~60 px) inside the region
      if (v.u > 180 && v.u < 460 && v.v > 120 && v.v < 240) out.push_back(v);
    return out;
  };
  const std::string view = "zoom=0&w=360&h=640";
  const std::vector<MeshVertex> before = inside(vertices_of(mesh("marked", view)));
  const json regions = {{"regions", {{{"rect", {120, 60, 400, 240}}, {"weight", 1}}}}};
  auto r = http.request("PATCH", "/v1/images/marked/significance", regions.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  const std::vector<MeshVertex> after = inside(vertices_of(mesh("marked", view)));
  ASSERT_GE(before.size(), 4u);
  ASSERT_GE(after.size(), 4u);
  const SimilarityFit fit_before = similarity_fit(before), fit_after = similarity_fit(after);
  std::printf("[ figures ] marked region: similarity residual %.2e before the edit, %.2e after; rotation %.2e\n",
              fit_before.residual, fit_after.residual, fit_after.rotation);
  EXPECT_GT(fit_before.residual, 0.05) << "the stretch to 9:16 distorts an unmarked region";
  // The JSON's 0.001 px rounding over a region of ~100 screen px.
  EXPECT_LT(fit_after.residual, 1e-4);
  EXPECT_NEAR(fit_after.rotation, 0, 1e-4);
}

// A region marked important, then a curator's line, each write the new version's patch files
// (the edited map; the line term), and the warp follows them: the mesh of the same view changes.
TEST_F(MeshMethods, PatchFollowsSignificanceAndLineEdits) {
  upload("patched");
  const std::string dir = fs::canonical(store() + "/images/patched").string();
  const std::string file_before = testing::read_file(dir + "/patch.default.bin");
  const json before = mesh("patched", "zoom=0&w=360&h=640", "patch");
  const json regions = {{"regions", {{{"rect", {0, 500, 900, 225}}, {"weight", 1}}}}};
  auto r = http.request("PATCH", "/v1/images/patched/significance", regions.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  const std::string after_dir = fs::canonical(store() + "/images/patched").string();
  EXPECT_NE(testing::read_file(after_dir + "/patch.default.bin"), file_before);
  const json after = mesh("patched", "zoom=0&w=360&h=640", "patch");
  EXPECT_NE(after["image"]["version"], before["image"]["version"]);
  EXPECT_GT(max_screen_shift(vertices_of(before), vertices_of(after)), 1) << "the warp follows the edit";

  const std::string file_marked = testing::read_file(after_dir + "/patch.default.bin");
  const json lines = {{"lines", {{150, 560, 1130, 700}}}};
  r = http.request("PUT", "/v1/images/patched/lines", lines.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  const std::string lined_dir = fs::canonical(store() + "/images/patched").string();
  EXPECT_NE(testing::read_file(lined_dir + "/patch.default.bin"), file_marked) << "lines are in patch's energy";
  const json lined = mesh("patched", "zoom=0&w=360&h=640", "patch");
  EXPECT_GT(max_screen_shift(vertices_of(after), vertices_of(lined)), 0.1) << "the warp follows the line";
}

// The sky from (120, 60) to (520, 300) marked as important: the edit writes the new version's
// polyfem files, the warp of the same view moves, and the sky, which the stretch to 9:16
// distorted, is distorted less (s = 1 there pulls J toward I [PolyFEM eq. 11], a similarity once
// zoomed).
TEST_F(MeshMethods, PolyfemFollowsASignificanceEdit) {
  upload("polyfem-marked");
  const std::string dir = fs::canonical(store() + "/images/polyfem-marked").string();
  const std::string file_before = testing::read_file(dir + "/polyfem.default.bin");
  const std::string view = "zoom=0&w=360&h=640&fit=warp";  // the whole image, every point on it
  const json before = mesh("polyfem-marked", view, "polyfem");
  const json regions = {{"regions", {{{"rect", {120, 60, 400, 240}}, {"weight", 1}}}}};
  auto r = http.request("PATCH", "/v1/images/polyfem-marked/significance", regions.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  const std::string after_dir = fs::canonical(store() + "/images/polyfem-marked").string();
  // Not EXPECT_NE: a failure would print both files (~1 MB each).
  EXPECT_TRUE(testing::read_file(after_dir + "/polyfem.default.bin") != file_before) << "the edit rewrites the file";
  const json after = mesh("polyfem-marked", view, "polyfem");
  EXPECT_NE(after["image"]["version"], before["image"]["version"]);

  // The edit remeshes (the cells follow the map's edges): compare image points, not vertices.
  double shift = 0;
  for (double u = 40; u < 1280; u += 80)
    for (double v = 40; v < 800; v += 80) {
      const auto [x0, y0] = screen_position(before, u, v);
      const auto [x1, y1] = screen_position(after, u, v);
      ASSERT_FALSE(std::isnan(x0 + x1)) << "(" << u << ", " << v << ") is in no triangle";
      shift = std::max(shift, std::hypot(x1 - x0, y1 - y0));
    }
  const auto sky = [](const json& mesh) {  // 20 px inside the region
    std::vector<MeshVertex> out;
    for (const MeshVertex& v : vertices_of(mesh))
      if (v.u > 140 && v.u < 500 && v.v > 80 && v.v < 280) out.push_back(v);
    return out;
  };
  const double residual_before = similarity_fit(sky(before)).residual, residual_after = similarity_fit(sky(after)).residual;
  std::printf("[ figures ] polyfem edit: image points moved up to %.1f px; sky's similarity residual %.3f before, %.3f after\n",
              shift, residual_before, residual_after);
  EXPECT_GT(shift, 1) << "the warp follows the edit";
  EXPECT_LT(residual_after, 0.8 * residual_before) << "the region marked important is distorted less";
}

}  // namespace
}  // namespace zoomwarp
