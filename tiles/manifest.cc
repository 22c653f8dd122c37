#include "tiles/manifest.h"

#include <nlohmann/json.hpp>
#include <stdexcept>

#include "tiles/image_id.h"

namespace zoomwarp::tiles {

int pyramid_levels(int width, int height) {
  int n = 1;
  for (long long d = std::max(width, height); d > 1; d = (d + 1) / 2) ++n;
  return n;
}

namespace {

// 64 lower-case hex digits, as file_sha256_hex writes them.
bool is_sha256_hex(const std::string& s) {
  if (s.size() != 64) return false;
  for (char c : s)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
}

}  // namespace

std::string manifest_to_json(const Manifest& m) {
  nlohmann::json j = {
      {"id", m.id},
      {"version", m.version},
      {"width", m.width},
      {"height", m.height},
      {"channels", m.channels},
      {"levels", m.levels},
      {"tile_size", m.tile_size},
      {"compression", m.compression},
      {"created_ms", m.created_ms},
      {"source",
       {{"format", m.source_format},
        {"bits", m.source_bits},
        {"channels", m.source_channels},
        {"orientation", m.source_orientation},
        {"bytes", m.source_bytes}}},
      {"private", m.is_private},
  };
  if (!m.source_sha256.empty()) j["source"]["sha256"] = m.source_sha256;
  if (m.compression == "jpeg")
    j["jpeg"] = {{"quality", m.jpeg.quality}, {"chroma_subsampling", {m.jpeg.chroma_h, m.jpeg.chroma_v}}};
  return j.dump(2) + "\n";
}

Manifest manifest_from_json(std::string_view text) {
  try {
    auto j = nlohmann::json::parse(text);
    Manifest m;
    m.id = j.at("id").get<std::string>();
    m.version = j.at("version").get<std::string>();
    m.width = j.at("width").get<int>();
    m.height = j.at("height").get<int>();
    m.channels = j.at("channels").get<int>();
    m.levels = j.at("levels").get<int>();
    m.tile_size = j.at("tile_size").get<int>();
    m.compression = j.value("compression", "");
    m.created_ms = j.value("created_ms", std::int64_t(0));
    m.is_private = j.value("private", false);
    if (auto s = j.find("source"); s != j.end()) {
      m.source_format = s->value("format", "");
      m.source_bits = s->value("bits", 8);
      m.source_channels = s->value("channels", 3);
      m.source_orientation = s->value("orientation", 1);
      m.source_bytes = s->value("bytes", std::int64_t(0));
      // Anything but a digest is read as unknown: it decides only whether `zoomwarp ingest` may
      // skip the file, never how the image is served, so it is no reason to refuse the image.
      if (std::string digest = s->value("sha256", ""); is_sha256_hex(digest)) m.source_sha256 = std::move(digest);
    }
    if (m.compression == "jpeg") {
      const auto& q = j.at("jpeg");
      const auto& sub = q.at("chroma_subsampling");
      m.jpeg = {q.at("quality").get<int>(), sub.at(0).get<int>(), sub.at(1).get<int>()};
      if (!is_valid(m.jpeg) || m.channels != 3) throw std::runtime_error("inconsistent manifest");
    }
    if (!is_valid_image_id(m.id) || m.width <= 0 || m.height <= 0 ||
        (m.channels != 3 && m.channels != 4) || m.tile_size <= 0 ||
        m.levels != pyramid_levels(m.width, m.height))
      throw std::runtime_error("inconsistent manifest");
    return m;
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(std::string("malformed manifest: ") + e.what());
  }
}

}  // namespace zoomwarp::tiles
