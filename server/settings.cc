#include "server/settings.h"

#include <stdexcept>

namespace zoomwarp::server {

std::vector<OptionSpec> store_option_specs() {
  return {
      {"store", "./store", "folder of the image store (shared by all replicas)"},
      {"max-pixels", "1000000000", "largest image accepted, in pixels (width x height), checked before decoding"},
      {"tile-compression", "zip", "TIFF compression of stored pyramid levels: zip, zstd, lzw, none"},
  };
}

tiles::IngestOptions ingest_options(const Options& o) {
  tiles::IngestOptions opt;
  opt.limits.max_pixels = std::uint64_t(o.integer("max-pixels", 1, 1LL << 40));
  opt.pyramid.compression = o.str("tile-compression");
  const auto& c = opt.pyramid.compression;
  if (c != "zip" && c != "zstd" && c != "lzw" && c != "none")
    throw std::invalid_argument("--tile-compression must be zip, zstd, lzw or none, not '" + c + "'");
  return opt;
}

}  // namespace zoomwarp::server
