// The warp engine on the wire: /mesh and /viewport over a sweep of views, the geomorph pair,
// curator edits, bad input, and the OpenAPI document against the running server.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/json_schema.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using nlohmann::json;
using testing::HttpClient;

struct Pt {
  double x, y;
};

double area2(const Pt& a, const Pt& b, const Pt& c) { return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x); }

class Views : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    server_ = new testing::ServerProcess(dir_->path() + "/store");
    HttpClient http(server_->port());
    for (auto [id, file] : {std::pair{"boats", "boats_lake_sunset.jpg"}, {"pano", "pano_grossmugl_field_4to1.png"},
                            {"edit", "boats_lake_sunset.jpg"}}) {
      auto r = http.request("POST", std::string("/v1/images?id=") + id, testing::read_file(testing::samples_dir() + "/" + file));
      ASSERT_EQ(r.status, 201) << r.body;
    }
    openapi_ = new json(json::parse(http.get("/openapi.json").body));
  }
  static void TearDownTestSuite() {
    delete openapi_;
    delete server_;
    delete dir_;
  }

  json mesh(const std::string& id, const std::string& query) {
    auto r = http.get("/v1/images/" + id + "/mesh?" + query);
    EXPECT_EQ(r.status, 200) << query << ": " << r.body;
    return r.status == 200 ? json::parse(r.body) : json();
  }

  HttpClient http{server_->port()};
  static testing::TempDir* dir_;
  static testing::ServerProcess* server_;
  static json* openapi_;
};
testing::TempDir* Views::dir_ = nullptr;
testing::ServerProcess* Views::server_ = nullptr;
json* Views::openapi_ = nullptr;

// What every mesh a client gets must be: valid against the schema, fold-free on screen, covering
// the screen, and at zoom 1 the identity crop.
void expect_drawable(const json& m, const json& openapi, double zoom, int w, int h) {
  const bool crop_possible = m["image"]["width"].get<int>() >= w && m["image"]["height"].get<int>() >= h;
  const auto problems = testing::validate_json(m, openapi["components"]["schemas"]["Mesh"], openapi);
  ASSERT_TRUE(problems.empty()) << problems.front();
  const auto& v = m["vertices"];
  auto screen = [&](int i) { return Pt{v[i][2].get<double>(), v[i][3].get<double>()}; };
  for (const auto& t : m["triangles"]) {
    for (int k = 0; k < 3; ++k) ASSERT_LT(t[k].get<std::size_t>(), v.size());
    ASSERT_GT(area2(screen(t[0]), screen(t[1]), screen(t[2])), 0) << "an inverted triangle";
  }
  // An image smaller than the screen along an axis may be letterboxed there (zoom 1 is 1:1):
  // then the bands are centred, and only the screen between them must be covered.
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (int i = 0; i < int(v.size()); ++i)
    x0 = std::min(x0, screen(i).x), x1 = std::max(x1, screen(i).x), y0 = std::min(y0, screen(i).y), y1 = std::max(y1, screen(i).y);
  if (crop_possible) {
    ASSERT_TRUE(x0 <= 0.01 && y0 <= 0.01 && x1 >= w - 0.01 && y1 >= h - 0.01) << "a black band";
  }
  if (x0 > 0.01 || x1 < w - 0.01) {
    ASSERT_NEAR(x0, w - x1, 2) << "bands not centred";
  }
  if (y0 > 0.01 || y1 < h - 0.01) {
    ASSERT_NEAR(y0, h - y1, 2) << "bands not centred";
  }
  for (int gy = 0; gy <= 8; ++gy)
    for (int gx = 0; gx <= 8; ++gx) {
      const Pt p{std::clamp(w * gx / 8.0, x0, x1), std::clamp(h * gy / 8.0, y0, y1)};
      bool covered = false;
      for (const auto& t : m["triangles"]) {
        const Pt a = screen(t[0]), b = screen(t[1]), c = screen(t[2]);
        if (area2(a, b, p) >= -1e-3 && area2(b, c, p) >= -1e-3 && area2(c, a, p) >= -1e-3) {
          covered = true;
          break;
        }
      }
      ASSERT_TRUE(covered) << "screen point (" << p.x << ", " << p.y << ") is not covered";
    }
  if (zoom == 1 && crop_possible) {  // else the screen is larger than the image along an axis
    const double ox = v[0][0].get<double>() - v[0][2].get<double>(), oy = v[0][1].get<double>() - v[0][3].get<double>();
    for (const auto& vert : v) {
      ASSERT_NEAR(vert[0].get<double>() - vert[2].get<double>(), ox, 0.5);
      ASSERT_NEAR(vert[1].get<double>() - vert[3].get<double>(), oy, 0.5);
    }
  }
  ASSERT_FALSE(m["tiles"].empty());
}

TEST_F(Views, MeshesOverASweepAreDrawable) {
  int checked = 0;
  for (const char* id : {"boats", "pano"})
    for (auto [w, h] : {std::pair{480, 360}, {360, 640}})
      for (double zoom : {0.0, 0.3, 0.6, 1.0})
        for (double fx : {0.2, 0.5, 0.85}) {
          const json info = json::parse(http.get(std::string("/v1/images/") + id).body);
          const double cx = fx * info["width"].get<double>(), cy = 0.4 * info["height"].get<double>();
          const std::string q = "zoom=" + std::to_string(zoom) + "&cx=" + std::to_string(cx) + "&cy=" + std::to_string(cy) +
                                "&w=" + std::to_string(w) + "&h=" + std::to_string(h);
          SCOPED_TRACE(std::string(id) + " " + q);
          expect_drawable(mesh(id, q), *openapi_, zoom, w, h);
          ++checked;
        }
  EXPECT_EQ(checked, 48);
}

TEST_F(Views, ViewportAtZoomOneIsTheIiifCrop) {
  // cx - w/2 and cy - h/2 whole, so the crop is pixel-aligned.
  auto r = http.get("/v1/images/boats/viewport?zoom=1&cx=1000&cy=700&w=480&h=360&format=png");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.header("content-type"), "image/png");
  const tiles::Raster viewport = testing::decode_image(r.body);
  ASSERT_EQ(viewport.width, 480);
  ASSERT_EQ(viewport.height, 360);
  const tiles::Raster crop = testing::decode_image(http.get("/iiif/3/boats/760,520,480,360/max/0/default.png").body);
  const double db = testing::psnr(viewport, crop);
  std::printf("[ figures ] viewport at zoom 1 vs IIIF crop: %.1f dB\n", db);
  EXPECT_GE(db, 40);
  for (const char* format : {"jpg", "webp"}) {
    auto other = http.get(std::string("/v1/images/boats/viewport?zoom=0.5&w=320&h=240&format=") + format);
    ASSERT_EQ(other.status, 200);
    const tiles::Raster img = testing::decode_image(other.body);
    EXPECT_EQ(img.width, 320);
    EXPECT_EQ(img.height, 240);
  }
}

// Zoomed out, each triangle is drawn from the pyramid level that fits its scale: the traditional
// method's letterboxed z = 0 view is (between the bands) the IIIF downscale of the whole image.
TEST_F(Views, ZoomedOutViewportIsFilteredNotAliased) {
  const tiles::Raster viewport =
      testing::decode_image(http.get("/v1/images/boats/viewport?zoom=0&w=480&h=360&method=traditional&format=png").body);
  const tiles::Raster reference = testing::decode_image(http.get("/iiif/3/boats/full/480,300/0/default.png").body);
  const double db = testing::psnr(testing::crop(viewport, {0, 30, 480, 300}), reference);
  std::printf("[ figures ] zoomed-out viewport vs IIIF downscale: %.1f dB\n", db);
  EXPECT_GE(db, 35);
  for (int x : {0, 240, 479}) EXPECT_EQ(viewport.row(5)[x * 3], 0) << "the letterbox band is black";
}

// docs/algorithms.md "Quality rules", measured from the mesh JSON: the image's most significant tenth (by the
// served significance map) is less distorted than uniform stretching would distort it, and is
// shown larger than traditional zooming shows it. Boats (16:10) on a 9:16 phone screen, z = 0.
TEST_F(Views, SalientRegionsAreLargerAndLessDistorted) {
  const tiles::Raster sig = testing::decode_image(http.get("/v1/images/boats/significance.png").body);
  const double W = 2560, H = 1600, w = 360, h = 640;
  struct Measure {
    double salient_area = 0, distortion = 0;
  };
  auto measure = [&](const json& m) {
    const auto& v = m["vertices"];
    std::vector<std::pair<double, int>> by_significance;  // (significance at the centroid, triangle)
    for (std::size_t f = 0; f < m["triangles"].size(); ++f) {
      const auto& t = m["triangles"][f];
      double u = 0, vv = 0;
      for (int k = 0; k < 3; ++k) u += v[t[k].get<int>()][0].get<double>() / 3, vv += v[t[k].get<int>()][1].get<double>() / 3;
      const int x = std::clamp(int(u / W * sig.width), 0, sig.width - 1), y = std::clamp(int(vv / H * sig.height), 0, sig.height - 1);
      by_significance.emplace_back(sig.row(y)[x * sig.channels], int(f));
    }
    std::sort(by_significance.rbegin(), by_significance.rend());
    Measure out;
    double weight = 0;
    for (std::size_t i = 0; i < by_significance.size() / 10; ++i) {
      const auto& t = m["triangles"][by_significance[i].second];
      auto p = [&](int k, int c) { return v[t[k].get<int>()][c].get<double>(); };
      // The triangle's affine map: source edges (e1, e2) → screen edges; its singular values'
      // ratio is the anisotropy (1: shape kept).
      const double a = p(1, 0) - p(0, 0), b = p(2, 0) - p(0, 0), c = p(1, 1) - p(0, 1), d = p(2, 1) - p(0, 1);
      const double X1 = p(1, 2) - p(0, 2), X2 = p(2, 2) - p(0, 2), Y1 = p(1, 3) - p(0, 3), Y2 = p(2, 3) - p(0, 3);
      const double det = a * d - b * c;
      const double m11 = (X1 * d - X2 * c) / det, m12 = (X2 * a - X1 * b) / det;
      const double m21 = (Y1 * d - Y2 * c) / det, m22 = (Y2 * a - Y1 * b) / det;
      const double fro = m11 * m11 + m12 * m12 + m21 * m21 + m22 * m22, dj = std::abs(m11 * m22 - m12 * m21);
      const double s1 = std::sqrt((fro + std::sqrt(std::max(0.0, fro * fro - 4 * dj * dj))) / 2), s2 = dj / s1;
      const double area = std::abs(X1 * Y2 - X2 * Y1) / 2;
      out.salient_area += area;
      out.distortion += area * s1 / s2;
      weight += area;
    }
    out.distortion /= weight;
    return out;
  };
  const std::string view = "zoom=0&w=360&h=640";
  const Measure icaz = measure(mesh("boats", view));
  const Measure traditional = measure(mesh("boats", view + "&method=traditional"));
  const double uniform_stretch = (W / H) / (w / h);  // anisotropy of squeezing the image onto the screen
  std::printf("[ figures ] salient tenth: anisotropy %.2f (uniform stretch %.2f); screen area %.0f px² vs traditional %.0f px²\n",
              icaz.distortion, uniform_stretch, icaz.salient_area, traditional.salient_area);
  EXPECT_LT(icaz.distortion, uniform_stretch * 0.75);
  EXPECT_GT(icaz.salient_area, traditional.salient_area * 1.5);
}

TEST_F(Views, GeomorphPairStartsWhereThePreviousViewWas) {
  const std::string common = "&cx=1200&cy=700&w=480&h=360";
  const json before = mesh("boats", "zoom=0.5" + common);
  const json pair = mesh("boats", "zoom=0.6" + common + "&from_zoom=0.5");
  ASSERT_TRUE(pair.contains("from"));
  ASSERT_EQ(pair["from"].size(), pair["vertices"].size());
  expect_drawable(pair, *openapi_, 0.6, 480, 360);
  std::map<std::pair<long long, long long>, Pt> previous;  // by source position (1/1000 px)
  for (const auto& v : before["vertices"])
    previous[{std::llround(v[0].get<double>() * 1000), std::llround(v[1].get<double>() * 1000)}] = {v[2].get<double>(), v[3].get<double>()};
  int shared = 0;
  for (std::size_t i = 0; i < pair["vertices"].size(); ++i) {
    const auto& v = pair["vertices"][i];
    auto it = previous.find({std::llround(v[0].get<double>() * 1000), std::llround(v[1].get<double>() * 1000)});
    if (it == previous.end()) continue;
    ++shared;
    EXPECT_NEAR(pair["from"][i][0].get<double>(), it->second.x, 0.01);
    EXPECT_NEAR(pair["from"][i][1].get<double>(), it->second.y, 0.01);
  }
  EXPECT_GT(shared, 20);
  // The baselines pair vertex by vertex too.
  const json traditional = mesh("boats", "zoom=0.6" + common + "&from_zoom=0.5&method=traditional");
  EXPECT_EQ(traditional["from"].size(), traditional["vertices"].size());
}

TEST_F(Views, AnEditChangesVersionEtagAndResult) {
  const std::string target = "/v1/images/edit/mesh?zoom=0&w=360&h=480";
  auto first = http.get(target);
  ASSERT_EQ(first.status, 200);
  const std::string etag = first.header("etag");
  EXPECT_EQ(http.get(target, {{"If-None-Match", etag}}).status, 304);
  const std::string v1 = json::parse(http.get("/v1/images/edit").body)["version"];

  auto patch = http.request("PATCH", "/v1/images/edit/significance",
                            R"({"regions": [{"rect": [1800, 200, 500, 400], "weight": 1}, {"polygon": [[100, 1100], [500, 1100], [300, 1500]], "weight": 0.1}]})",
                            {{"Content-Type", "application/json"}});
  ASSERT_EQ(patch.status, 200) << patch.body;
  const std::string v2 = json::parse(patch.body)["version"];
  EXPECT_NE(v1, v2);
  auto after = http.get(target, {{"If-None-Match", etag}});
  ASSERT_EQ(after.status, 200) << "the old ETag no longer matches";
  EXPECT_NE(after.header("etag"), etag);
  EXPECT_NE(json::parse(after.body)["vertices"], json::parse(first.body)["vertices"]);
  EXPECT_EQ(json::parse(after.body)["image"]["version"], v2);

  auto put = http.request("PUT", "/v1/images/edit/lines", R"({"lines": [[0, 1000, 2560, 1000], [300, 100, 900, 1500]]})");
  ASSERT_EQ(put.status, 200) << put.body;
  EXPECT_EQ(json::parse(http.get("/v1/images/edit/lines").body)["lines"].size(), 2u);
  expect_drawable(mesh("edit", "zoom=0.7&cx=700&cy=1000&w=480&h=360"), *openapi_, 0.7, 480, 360);
  auto png = http.get("/v1/images/edit/significance.png");
  ASSERT_EQ(png.status, 200);
  EXPECT_EQ(testing::decode_image(png.body).width, 640);

  // If-Match with a stale image ETag is refused.
  auto stale = http.request("PUT", "/v1/images/edit/lines", R"({"lines": []})", {{"If-Match", "\"stale\""}});
  EXPECT_EQ(stale.status, 412);
}

TEST_F(Views, BadInputIsA400WithAJsonError) {
  const std::string base = "/v1/images/boats/";
  const char* bad_views[] = {
      "mesh?zoom=0.5",  // w, h missing
      "mesh?w=480&h=360&zoom=nan", "mesh?w=480&h=360&zoom=inf", "mesh?w=480&h=360&zoom=-0.1", "mesh?w=480&h=360&zoom=1.5",
      "mesh?w=480&h=360&zoom=1e3", "mesh?w=480&h=360&cx=-5", "mesh?w=480&h=360&cx=99999999999", "mesh?w=480&h=360&cy=abc",
      "mesh?w=5000&h=360", "mesh?w=15&h=360", "mesh?w=480.5&h=360", "mesh?w=480&h=360&method=magic",
      "mesh?w=480&h=360&curve=cubic", "mesh?w=480&h=360&zoom=0.1&zoom=0.2", "mesh?w=480&h=360&what=1",
      "mesh?w=480&h=360&from_zoom=2", "viewport?w=480&h=360&format=gif", "viewport?w=480&h=360&quality=0",
      "viewport?w=480&h=360&from_zoom=0.5", "mesh?w=480&h=360&zoom=%zz"};
  for (const char* q : bad_views) {
    auto r = http.get(base + q);
    EXPECT_EQ(r.status, 400) << q;
    EXPECT_NO_THROW(EXPECT_TRUE(json::parse(r.body).contains("error")) << q) << q;
  }
  const std::pair<const char*, const char*> bad_edits[] = {
      {"PUT", "{\"lines\": [[0, 0, 3000, 0]]}"},        // outside the image
      {"PUT", "{\"lines\": [[10, 10, 10, 10.2]]}"},      // shorter than a pixel
      {"PUT", "{\"lines\": [[0, 0, 100]]}"},
      {"PUT", "{\"lines\": \"no\"}"},
      {"PUT", "{lines: []}"},                            // malformed JSON
      {"PATCH", "{\"regions\": [{\"polygon\": [[0, 0], [10, 0]], \"weight\": 1}]}"},
      {"PATCH", "{\"regions\": [{\"rect\": [0, 0, 10, 10], \"weight\": 2}]}"},
      {"PATCH", "{\"regions\": [{\"rect\": [0, 0, -10, 10], \"weight\": 1}]}"},
      {"PATCH", "{\"regions\": [{\"rect\": [0, 0, 1e400, 10], \"weight\": 1}]}"},
      {"PATCH", "{\"regions\": []}"},
      {"PATCH", ""},
  };
  const std::string version = json::parse(http.get("/v1/images/boats").body)["version"];
  for (auto [method, body] : bad_edits) {
    auto r = http.request(method, base + (std::string(method) == "PUT" ? "lines" : "significance"), body);
    EXPECT_EQ(r.status, 400) << method << " " << body << ": " << r.body;
  }
  EXPECT_EQ(json::parse(http.get("/v1/images/boats").body)["version"], version) << "nothing was published";
  auto huge = http.request("PUT", base + "lines", std::string(2 << 20, ' '));
  EXPECT_EQ(huge.status, 413) << "a body over the limit";
  EXPECT_EQ(http.get("/v1/images/nope/mesh?w=480&h=360").status, 404);
  EXPECT_EQ(http.request("POST", base + "mesh?w=480&h=360").status, 405);
}

// Every documented route answers on the running server: with an unknown image id the image
// routes say "image_not_found" (the route exists), the others do not say "not_found".
TEST_F(Views, EveryDocumentedRouteIsServed) {
  for (const auto& [path, item] : (*openapi_)["paths"].items())
    for (const auto& [method, op] : item.items()) {
      if (method == "parameters") continue;
      std::string target = path;
      for (auto [name, value] : {std::pair{"{id}", "no_such_image"}, {"{level}", "0"}, {"{tile}", "0_0.jpg"},
                                 {"{region}", "full"}, {"{size}", "max"}, {"{rotation}", "0"}, {"{quality}", "default"},
                                 {"{format}", "jpg"}, {"{file}", "viewer"}, {"{page}", "1"}})
        if (auto at = target.find(name); at != std::string::npos) target.replace(at, std::string(name).size(), value);
      std::string m = method;
      for (char& c : m) c = char(std::toupper(static_cast<unsigned char>(c)));
      if (m == "GET" && (target.find("viewport") != std::string::npos || target.find("mesh") != std::string::npos))
        target += "?w=480&h=360";
      auto r = http.request(m, target, m == "GET" || m == "DELETE" ? "" : "{}");
      SCOPED_TRACE(m + " " + target + " -> " + std::to_string(r.status) + " " + r.body);
      EXPECT_NE(r.status, 405);
      if (r.status == 404) {
        const std::string code = json::parse(r.body)["error"]["code"];
        EXPECT_NE(code, "not_found");
      }
    }
}

}  // namespace
}  // namespace zoomwarp
