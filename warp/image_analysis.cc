#include "warp/image_analysis.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

namespace zoomwarp::warp {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr char kSignificanceMagic[8] = {'Z', 'W', 'S', 'I', 'G', '1', 0, 0};
constexpr char kModelMagic[8] = {'Z', 'W', 'M', 'O', 'D', 'E', 'L', '1'};

template <typename T>
void put(std::ostream& out, const T& v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof v);
}

template <typename T>
void put_vector(std::ostream& out, const std::vector<T>& v) {
  put(out, std::int64_t(v.size()));
  out.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(T)));
}

template <typename T>
T get(std::istream& in) {
  T v{};
  in.read(reinterpret_cast<char*>(&v), sizeof v);
  if (!in) throw std::runtime_error("truncated model file");
  return v;
}

template <typename T>
std::vector<T> get_vector(std::istream& in, std::int64_t max_size) {
  const auto n = get<std::int64_t>(in);
  if (n < 0 || n > max_size) throw std::runtime_error("damaged model file");
  std::vector<T> v(static_cast<std::size_t>(n));
  in.read(reinterpret_cast<char*>(v.data()), std::streamsize(v.size() * sizeof(T)));
  if (!in) throw std::runtime_error("truncated model file");
  return v;
}

// Writes `bytes` to dir/name through a temporary file renamed into place: a reader never sees a
// partial file, and a hard link to an older version's file is replaced, not written through.
void replace_file(const std::string& dir, const std::string& name, const std::string& bytes) {
  const fs::path tmp = fs::path(dir) / (name + ".tmp"), path = fs::path(dir) / name;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    if (!out.flush()) throw std::runtime_error("cannot write " + tmp.string());
  }
  fs::rename(tmp, path);
}

std::string read_whole(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("missing " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

json point_json(const Point& p) { return json::array({p.x, p.y}); }
Point point_from(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>()}; }

std::string model_json(const ImageModel& m) {
  json lines = json::array(), edits = json::array();
  for (const Segment& s : m.lines) lines.push_back({{"from", point_json(s.a)}, {"to", point_json(s.b)}});
  for (const SignificanceEdit& e : m.edits) {
    json polygon = json::array();
    for (const Point& p : e.polygon) polygon.push_back(point_json(p));
    edits.push_back({{"polygon", polygon}, {"weight", e.weight}});
  }
  return json{{"lines", lines}, {"significance_edits", edits}}.dump(2) + "\n";
}

std::string significance_bytes(const SignificanceMap& map) {
  std::ostringstream out;
  out.write(kSignificanceMagic, sizeof kSignificanceMagic);
  put(out, std::int32_t(map.width));
  put(out, std::int32_t(map.height));
  put(out, map.scale);
  out.write(reinterpret_cast<const char*>(map.values.data()), std::streamsize(map.values.size() * sizeof(float)));
  return out.str();
}

std::string model_bytes(const ImageModel& m) {
  std::ostringstream out;
  out.write(kModelMagic, sizeof kModelMagic);
  put(out, m.width), put(out, m.height), put(out, m.w_min), put(out, m.coarse.max_triangle_area);
  put_vector(out, m.coarse.mesh.vertices);
  put_vector(out, m.coarse.mesh.triangles);
  put(out, std::int64_t(m.coarse.line_vertices.size()));
  for (const auto& chain : m.coarse.line_vertices) put_vector(out, chain);
  m.forest.write(out);
  put_vector(out, m.node_mean);
  return out.str();
}

}  // namespace

tiles::Raster read_reduced_image(const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  const tiles::Manifest& m = image.manifest;
  int k = 0;
  while (k + 1 < m.levels && std::max(m.level_width(k), m.level_height(k)) > kSignificanceMaxSide) ++k;
  return reader.read_level(image, k, {0, 0, m.level_width(k), m.level_height(k)});
}

void write_image_analysis(const tiles::ImageEntry& image) {
  tiles::PyramidReader reader(32 << 20);  // its own small cache: staged files are about to move
  write_image_model(image.dir, make_image_model(read_reduced_image(image, reader), image.manifest.width,
                                                image.manifest.height));
}

void write_image_model(const std::string& dir, const ImageModel& model) {
  replace_file(dir, kSignificanceFile, significance_bytes(model.significance));
  replace_file(dir, kModelFile, model_bytes(model));
  replace_file(dir, kModelJsonFile, model_json(model));
}

SignificanceMap read_significance(const tiles::ImageEntry& image) {
  const std::string path = image.dir + "/" + kSignificanceFile;
  std::istringstream in(read_whole(path));
  char magic[8];
  in.read(magic, sizeof magic);
  SignificanceMap map;
  const auto w = get<std::int32_t>(in), h = get<std::int32_t>(in);
  map.scale = get<double>(in);
  if (std::memcmp(magic, kSignificanceMagic, sizeof magic) != 0 || w <= 0 || h <= 0 || w > 4 * kSignificanceMaxSide ||
      h > 4 * kSignificanceMaxSide || !(map.scale > 0))
    throw std::runtime_error("damaged " + path);
  map.width = w, map.height = h;
  map.values.resize(std::size_t(w) * h);
  in.read(reinterpret_cast<char*>(map.values.data()), std::streamsize(map.values.size() * sizeof(float)));
  if (!in) throw std::runtime_error("truncated " + path);
  return map;
}

ImageModel read_image_model(const tiles::ImageEntry& image) {
  ImageModel m;
  m.significance = read_significance(image);
  const std::string json_path = image.dir + "/" + kModelJsonFile, bin_path = image.dir + "/" + kModelFile;
  try {
    const json j = json::parse(read_whole(json_path));
    for (const auto& l : j.at("lines")) m.lines.push_back({point_from(l.at("from")), point_from(l.at("to"))});
    for (const auto& e : j.at("significance_edits")) {
      SignificanceEdit edit;
      for (const auto& p : e.at("polygon")) edit.polygon.push_back(point_from(p));
      edit.weight = e.at("weight").get<float>();
      m.edits.push_back(std::move(edit));
    }
  } catch (const json::exception& e) {
    throw std::runtime_error("damaged " + json_path + ": " + e.what());
  }
  std::istringstream in(read_whole(bin_path));
  char magic[8];
  in.read(magic, sizeof magic);
  if (!in || std::memcmp(magic, kModelMagic, sizeof magic) != 0) throw std::runtime_error("damaged " + bin_path);
  m.width = get<double>(in), m.height = get<double>(in), m.w_min = get<double>(in);
  m.coarse.max_triangle_area = get<double>(in);
  if (m.width != image.manifest.width || m.height != image.manifest.height)
    throw std::runtime_error(bin_path + " is for another image size");
  constexpr std::int64_t kMax = std::int64_t(1) << 26;
  m.coarse.mesh.vertices = get_vector<Point>(in, kMax);
  m.coarse.mesh.triangles = get_vector<Triangle>(in, kMax);
  for (const Triangle& t : m.coarse.mesh.triangles)
    for (int v : t)
      if (v < 0 || v >= int(m.coarse.mesh.vertices.size())) throw std::runtime_error("damaged " + bin_path);
  const auto chains = get<std::int64_t>(in);
  if (chains < 0 || chains != std::int64_t(m.lines.size())) throw std::runtime_error("damaged " + bin_path);
  for (std::int64_t k = 0; k < chains; ++k) m.coarse.line_vertices.push_back(get_vector<int>(in, kMax));
  m.forest = Forest::read(in, m.coarse.mesh);
  m.node_mean = get_vector<float>(in, kMax);
  if (m.node_mean.size() != std::size_t(m.forest.kept_nodes())) throw std::runtime_error("damaged " + bin_path);
  return m;
}

void validate(const ModelEdit& edit) {
  auto finite = [](const Point& p) { return std::isfinite(p.x) && std::isfinite(p.y); };
  if (edit.lines) {
    if (edit.lines->size() > 1000) throw std::invalid_argument("at most 1000 lines");
    for (const Segment& s : *edit.lines) {
      if (!finite(s.a) || !finite(s.b)) throw std::invalid_argument("line end points must be finite numbers");
      if (std::hypot(s.b.x - s.a.x, s.b.y - s.a.y) < 1) throw std::invalid_argument("a line must be at least 1 px long");
    }
  }
  if (edit.significance.size() > 1000) throw std::invalid_argument("at most 1000 significance edits at once");
  for (const SignificanceEdit& e : edit.significance) {
    if (e.polygon.size() < 3 || e.polygon.size() > 1000) throw std::invalid_argument("a region needs 3 to 1000 points");
    for (const Point& p : e.polygon)
      if (!finite(p)) throw std::invalid_argument("region points must be finite numbers");
    if (!(e.weight >= 0 && e.weight <= 1)) throw std::invalid_argument("a region's weight must be in [0, 1]");
  }
}

std::shared_ptr<const tiles::ImageEntry> edit_image_model(tiles::Store& store, const tiles::ImageEntry& current,
                                                          const ModelEdit& edit, std::optional<ImageModel> base) {
  validate(edit);
  ImageModel model = base ? std::move(*base) : read_image_model(current);
  for (const SignificanceEdit& e : edit.significance) add_significance_edit(model, e);
  // New lines rebuild the mesh and the forest, whose node means then read the edited map.
  if (edit.lines) set_lines(model, *edit.lines);
  const std::string staging = store.make_staging_copy(current);
  try {
    write_image_model(staging, model);
  } catch (...) {
    store.discard(staging);
    throw;
  }
  return store.publish(staging, current.manifest, &current.manifest.version);
}

}  // namespace zoomwarp::warp
