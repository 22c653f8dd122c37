#include "server/settings.h"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>

#include "api/description.h"
#include "server/log.h"
#include "warp/analysis/image_analysis.h"

namespace zoomwarp::server {

std::vector<OptionSpec> store_option_specs() {
  return {
      {"store", "./store", "the image store: a folder, or s3://BUCKET/PREFIX (credentials and endpoint from AWS_* variables; docs/s3.md), shared by all replicas"},
      {"max-pixels", "1000000000", "largest image accepted, in pixels (width x height), checked before decoding"},
      {"max-decode-memory", "4G",
       "most memory an ingest's decoder may hold: sources read by strips or tiles stay far below it; one that must be "
       "decoded whole (a JPEG 2000 with subsampled or palette colour, an image turned by its EXIF orientation) and "
       "needs more is refused before decoding"},
      {"tile-compression", "auto",
       "compression of stored pyramid tiles: auto (JPEG for lossy sources - JPEG, lossy WebP - and zip:1 for the others), "
       "jpeg (every source without alpha), or lossless for every source: zip:1 … zip:9, zip (= zip:6), lzw, none"},
      {"tile-quality", "90",
       "JPEG tiles' quality, 1-100, at most: a JPEG source of lower quality is stored at its own"},
      {"ingest-threads", std::to_string(std::max(1u, std::thread::hardware_concurrency())),
       "threads one ingest uses: tiles compressed and the warp analysis's parts run on all of them (same files for any count)"},
      {"analyses", "none",
       "what an ingest or upload analyses before it publishes: none (every analysis is made on a view's first use "
       "and kept with the image), icaz (ICAZ's model and the detected lines), or all (every method, both saliency "
       "kinds); `zoomwarp analyse` fills in a store later"},
      {"face-cascade", warp::kDefaultFaceCascade,
       "OpenCV Haar cascade for faces in significance maps (the default is also looked for in OpenCV's data folders); "
       "missing: face detection is off"},
  };
}

std::vector<OptionSpec> bucket_store_option_specs() {
  return {
      {"store-cache", "",
       "with an s3:// store: a local folder for uploads being staged and a disk cache of the bucket's bytes (tile "
       "indexes, tiles, analyses), kept across restarts; empty: staging in $TMPDIR, memory cache only"},
      {"store-cache-bytes", "10G", "with --store-cache: the disk cache's bound, oldest evicted first"},
      {"store-memory-bytes", "256M", "with an s3:// store: the bucket's bytes kept in memory"},
      {"store-lease-ms", "10000",
       "with an s3:// store: how long the lease a replica holds while it moves an image's pointer lasts if the replica "
       "dies (docs/s3-operations.md)"},
      {"store-lease-settle-ms", "300",
       "with an s3:// store: how long a replica waits before trusting a lease it wrote; longer than the store's "
       "slowest GET-then-PUT"},
  };
}

tiles::BucketStoreOptions bucket_store_options(const Options& o) {
  tiles::BucketStoreOptions c;
  c.dir = o.str("store-cache");
  c.disk_bytes = o.bytes("store-cache-bytes", 1ULL << 20, 1ULL << 50);
  c.memory_bytes = std::size_t(o.bytes("store-memory-bytes", 1ULL << 20, 1ULL << 40));
  c.lease.settle = std::chrono::milliseconds(o.integer("store-lease-settle-ms", 1, 60'000));
  c.lease.ttl = std::chrono::milliseconds(o.integer("store-lease-ms", 1'000, 3'600'000));
  if (c.lease.ttl <= c.lease.skew + c.lease.settle)
    throw std::invalid_argument("--store-lease-ms must be longer than --store-lease-settle-ms plus the 2 s allowed for clock skew");
  return c;
}

AnalysisSettings analysis_settings(const Options& o) {
  const std::string configured = o.str("face-cascade");
  const warp::FaceCascade cascade = warp::find_face_cascade(configured);
  AnalysisSettings s;
  s.significance.face_cascade = cascade.path;
  if (cascade.path.empty()) {
    s.face_detection = "off: " + cascade.problem;
    log_event("warn", "face detection is off: significance maps will not boost faces",
              {{"face_cascade", configured}, {"problem", cascade.problem}});
  } else {
    s.face_detection = "on";
  }
  return s;
}

tiles::IngestOptions ingest_options(const Options& o, const warp::SignificanceOptions& significance,
                                    std::vector<warp::MethodFileTiming>* method_timings) {
  tiles::IngestOptions opt;
  opt.limits.max_pixels = std::uint64_t(o.integer("max-pixels", 1, 1LL << 40));
  opt.limits.max_decode_bytes = o.bytes("max-decode-memory", 1ULL << 20, 1ULL << 50);
  opt.pyramid.compression = o.str("tile-compression");
  opt.pyramid.jpeg_quality = int(o.integer("tile-quality", 1, 100));
  opt.pyramid.threads = int(o.integer("ingest-threads", 1, 256));
  const auto& c = opt.pyramid.compression;
  const bool zip_level = c.size() == 5 && c.rfind("zip:", 0) == 0 && c[4] >= '1' && c[4] <= '9';
  if (c != "auto" && c != "jpeg" && c != "zip" && !zip_level && c != "lzw" && c != "none")
    throw std::invalid_argument("--tile-compression must be auto, jpeg, zip:1 … zip:9, zip, lzw or none, not '" + c + "'");
  const auto set = warp::parse_analysis_set(o.str("analyses"));
  if (!set) throw std::invalid_argument("--analyses must be none, icaz or all, not '" + o.str("analyses") + "'");
  // A re-ingest keeps the curator's description unless it gives one (api/description.h).
  opt.carry = api::carry_description();
  // The warp engine's files published with the image: those asked for; the others on first use.
  opt.analyse = [significance, method_timings, threads = opt.pyramid.threads, set = *set](const tiles::ImageEntry& staged) {
    auto timings = warp::write_image_analysis(staged, significance, threads, set);
    if (method_timings) *method_timings = std::move(timings);
  };
  return opt;
}

}  // namespace zoomwarp::server
