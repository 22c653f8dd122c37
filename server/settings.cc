#include "server/settings.h"

#include <stdexcept>

#include "warp/image_analysis.h"

namespace zoomwarp::server {

std::vector<OptionSpec> store_option_specs() {
  return {
      {"store", "./store", "folder of the image store (shared by all replicas)"},
      {"max-pixels", "1000000000", "largest image accepted, in pixels (width x height), checked before decoding"},
      {"tile-compression", "zip:1", "TIFF compression of stored pyramid levels: zip:1 … zip:9, zip (= zip:6), lzw, none"},
  };
}

tiles::IngestOptions ingest_options(const Options& o) {
  tiles::IngestOptions opt;
  opt.limits.max_pixels = std::uint64_t(o.integer("max-pixels", 1, 1LL << 40));
  opt.pyramid.compression = o.str("tile-compression");
  const auto& c = opt.pyramid.compression;
  const bool zip_level = c.size() == 5 && c.rfind("zip:", 0) == 0 && c[4] >= '1' && c[4] <= '9';
  if (c != "zip" && !zip_level && c != "lzw" && c != "none")
    throw std::invalid_argument("--tile-compression must be zip:1 … zip:9, zip, lzw or none, not '" + c + "'");
  opt.analyse = warp::write_image_analysis;  // the warp engine's significance map, published with the image
  return opt;
}

}  // namespace zoomwarp::server
