// `zoomwarp serve`: wires the store, the pyramid reader, the router and the HTTP server together.
#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <thread>

#include "api/key_ring.h"
#include "api/router.h"
#include "server/commands.h"
#include "server/compute_hook.h"
#include "server/http_server.h"
#include "server/log.h"
#include "server/metrics.h"
#include "server/settings.h"
#include "server/worker_pool.h"
#include "tiles/pyramid_reader.h"
#include "tiles/store.h"

namespace zoomwarp::server {

namespace {

std::vector<OptionSpec> serve_specs() {
  const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<OptionSpec> specs = {
      {"host", "127.0.0.1", "address to listen on (0.0.0.0 for all interfaces)"},
      {"port", "8080", "TCP port; 0 picks a free one (see the 'listening' log line)"},
      // Half the CPUs: each I/O thread owns its connections (server/README.md "Threads"), so one
      // that loses its core to a worker or a co-located client stalls them; with half the cores
      // for I/O, cached tiles kept their p99 within 3× p50 on 2 cores, at 0.80-0.88× nginx.
      {"io-threads", std::to_string(std::max(1, cores / 2)), "threads doing network I/O and answering cached requests"},
      {"workers", std::to_string(cores), "threads decoding, resampling and encoding"},
      {"queue", "256", "requests that may wait for a worker before new ones get 503"},
      {"ingest-workers", "1", "uploads ingested at the same time"},
      {"ingest-queue", "4", "uploads that may wait to be ingested before new ones get 503"},
      {"tile-cache", "256M", "decoded-tile cache size (bytes, K/M/G)"},
      {"response-cache", "256M", "encoded-response cache size (bytes, K/M/G)"},
      {"warp-cache", "256M", "memory for the warp engines of recently viewed images (bytes, K/M/G)"},
      {"max-upload", "512M", "largest upload body (bytes, K/M/G)"},
      {"max-staging", "0", "upload bytes staged at once, by Content-Length (chunked: --max-upload); 0: no cap"},
      {"iiif-max-width", "8192", "IIIF maxWidth: widest image returned"},
      {"iiif-max-height", "8192", "IIIF maxHeight: tallest image returned"},
      {"iiif-max-area", "16777216", "IIIF maxArea: most pixels in one image returned"},
      // 256/0 is the stored tiles' grid: Deep Zoom JPEG tiles of JPEG-tiled images are then sent as
      // stored, without decoding (api/README.md "Stored tiles sent as they are").
      {"dzi-tile-size", "254", "Deep Zoom TileSize, 64-2048 (256 with --dzi-overlap 0: JPEG tiles sent as stored)"},
      {"dzi-overlap", "1", "Deep Zoom Overlap, pixels, 0-8"},
      {"jpeg-quality", "85", "JPEG quality of every answer that is encoded, 1-100 (stored tiles sent as they are keep the image's tile quality)"},
      {"webp-quality", "80", "WebP quality, 1-100"},
      {"avif-quality", "60", "AVIF quality, 1-100 (AV1 quantizer (100 - q) * 63 / 100)"},
      {"avif-speed", "10", "AVIF encoder speed, 0 (slowest, smallest) to 10 (fastest)"},
      {"jxl-quality", "80", "JPEG XL quality, 1-100 (as cjxl's: Butteraugli distance 0.1 + (100 - q) * 0.09)"},
      {"jxl-effort", "3", "JPEG XL encoder effort, 1 (fastest) to 9 (slowest, smallest)"},
      {"cache-max-age", "60", "Cache-Control max-age of image responses, seconds"},
      {"public-url", "", "base URL clients see (for IIIF ids); default from the Host header"},
      {"idle-timeout", "30", "seconds an idle keep-alive connection is kept"},
      {"header-timeout", "10", "seconds from a request's first bytes to the end of its header"},
      {"body-timeout", "30", "seconds an upload's body may pause before the connection is dropped"},
      {"max-connections", "0", "connections open at once (more wait); 0: the open-file limit less 64"},
      {"drain-delay", "0", "seconds between SIGTERM (readiness fails) and closing the listener"},
      {"drain-timeout", "30", "seconds in-flight requests get to finish after the listener closed; then they are cancelled and the process exits"},
      {"request-timeout", "5", "seconds a computed request (view, tile, IIIF image, edit) may take from read to answer, queue included; then 503 + Retry-After"},
      // As long as the default --request-timeout: a client retrying a view that runs out of time
      // every time then holds one worker half of the time at most (server/README.md).
      {"analysis-threads", "1",
       "threads computing image analyses on first use and methods' warps for a new screen size, in the background below "
       "request priority; a view waits for them until --request-timeout, then 503 analysis_pending + Retry-After"},
      {"failure-cache-ms", "5000", "milliseconds a view that ran out of time or failed with a 500 is answered with that failure again (+ Retry-After) instead of being computed; 0: never"},
      {"gc-grace", "600", "seconds a superseded or deleted image version stays readable after it stopped being published; at least --store-recheck-ms, which replicas trust a version for"},
      {"store-recheck-ms", "1000", "milliseconds an image's published version, once read from the store, is trusted: another process's re-ingest or delete is seen within this (this server's own at once); 0: read on every request"},
      {"log-requests", "1", "one JSON log line per request (1/0)"},
      {"keys", "", "API key file, one 'KEY_ID ROLE KEY' per line (README \"Access\"); re-read when it changes and on SIGHUP. Without it writes are refused"},
      {"open-writes", "0", "without --keys, let anyone upload, delete and edit (demos and tests on loopback)", true},
      {"signing-key", "", "file holding the secret of signed URLs for private images (>= 32 random bytes, hex or raw: openssl rand -hex 32); none: no signed URLs"},
      {"cors-write-origins", "", "origins whose pages may write (POST, PUT, PATCH, DELETE), comma-separated, e.g. https://curate.example.org; reads are open to every origin"},
      {"trust-forwarded-for", "0", "behind a proxy: the client address (rate limits) is the last X-Forwarded-For entry (1/0)"},
      {"upload-rate", "0", "uploads per minute per key (or client address without one), N or N/min; 0: no limit"},
      {"upload-bytes-per-day", "0", "upload bytes per day per key (or client address without one), K/M/G; 0: no limit"},
  };
  for (auto& s : store_option_specs()) specs.push_back(s);
  for (auto& s : bucket_store_option_specs()) specs.push_back(s);
  return specs;
}

// Each connection takes a file descriptor; 64 are left for the store, the tile cache's open
// level files and the log. The limit is read at start-up.
std::size_t connections_for_fd_limit() {
  rlimit limit{};
  if (getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return 1 << 16;
  return std::size_t(limit.rlim_cur > 80 ? limit.rlim_cur - 64 : 16);
}

// --upload-rate: "N" or "N/min".
std::uint64_t upload_rate(std::string text) {
  if (text.size() > 4 && text.compare(text.size() - 4, 4, "/min") == 0) text.resize(text.size() - 4);
  const bool digits = !text.empty() && text.size() <= 9 && text.find_first_not_of("0123456789") == std::string::npos;
  if (!digits) throw std::invalid_argument("--upload-rate must be N or N/min, not '" + text + "'");
  return std::stoull(text);
}

// The key ring of --keys (null without), or --open-writes; they exclude each other, so a server
// with keys never also lets anyone write. Logs which way writes are governed.
std::unique_ptr<api::KeyRing> access_settings(const Options& o, api::AccessPolicy& access) {
  const std::string path = o.str("keys");
  access.open_writes = o.flag("open-writes");
  if (!path.empty() && access.open_writes)
    throw std::invalid_argument("--keys and --open-writes exclude each other: with keys, only their holders write");
  if (access.open_writes)
    log_event("warn", "open writes: anyone who reaches this server may upload, delete and edit images (--open-writes)");
  if (path.empty()) {
    if (!access.open_writes) log_event("info", "no --keys: uploads, deletions and edits are refused");
    return nullptr;
  }
  auto keys = std::make_unique<api::KeyRing>(
      path, [](std::string_view level, std::string_view msg) { log_event(level, msg); });
  log_event("info", "keys loaded", {{"keys", keys->size()}});
  access.keys = keys.get();
  return keys;
}

// The listener's address, limits, timeouts, CORS and upload rate policies. What the rest of the
// wiring knows (face detection's state, the key file's reload, the upload slots) is added by serve().
HttpServerOptions http_server_options(const Options& o) {
  HttpServerOptions http;
  http.host = o.str("host");
  http.port = int(o.integer("port", 0, 65535));
  http.io_threads = int(o.integer("io-threads", 1, 256));
  http.max_upload_bytes = o.bytes("max-upload", 1, 1ULL << 40);
  http.max_staging_bytes = o.bytes("max-staging", 0, 1ULL << 50);
  http.idle_timeout = std::chrono::seconds(o.integer("idle-timeout", 1, 3600));
  http.header_timeout = std::chrono::seconds(o.integer("header-timeout", 1, 3600));
  http.body_timeout = std::chrono::seconds(o.integer("body-timeout", 1, 3600));
  const auto max_connections = std::size_t(o.integer("max-connections", 0, 1 << 24));
  http.max_connections = max_connections > 0 ? max_connections : connections_for_fd_limit();
  http.drain_delay = std::chrono::seconds(o.integer("drain-delay", 0, 3600));
  http.drain_timeout = std::chrono::seconds(o.integer("drain-timeout", 0, 3600));
  http.request_timeout = std::chrono::seconds(o.integer("request-timeout", 1, 3600));
  http.gc_grace = std::chrono::seconds(o.integer("gc-grace", 0, 30 * 86400));
  // A replica trusts the version it read for --store-recheck-ms (tiles/superseded_versions.h): a
  // shorter grace lets another replica's collection remove what it still serves.
  if (const std::int64_t recheck_ms = o.integer("store-recheck-ms", 0, 3'600'000);
      std::chrono::milliseconds(recheck_ms) > http.gc_grace)
    throw std::invalid_argument("--gc-grace (" + std::to_string(http.gc_grace.count()) +
                                " s) must be at least --store-recheck-ms (" + std::to_string(recheck_ms) +
                                " ms): replicas trust a version that long, so it must stay readable that long after "
                                "it is replaced");
  http.log_requests = o.flag("log-requests");
  http.cors = CorsPolicy::parse(o.str("cors-write-origins"));
  http.trust_forwarded_for = o.flag("trust-forwarded-for");
  http.upload_limits.uploads_per_minute = upload_rate(o.str("upload-rate"));
  http.upload_limits.bytes_per_day = o.bytes("upload-bytes-per-day", 0, 1ULL << 50);
  return http;
}

// The router's caches, encoders, IIIF and Deep Zoom limits, ingest and analysis settings, URL
// signer and log; access_settings() adds who may write. Face detection's state goes to
// `*face_detection`: it is found with the analysis settings, and /readyz (the HTTP server) tells it.
api::RouterConfig router_config(const Options& o, std::string* face_detection) {
  api::RouterConfig rc;
  rc.response_cache_bytes = o.bytes("response-cache", 0, 1ULL << 40);
  rc.warp_cache_bytes = o.bytes("warp-cache", 1ULL << 20, 1ULL << 40);
  rc.encode.jpeg_quality = int(o.integer("jpeg-quality", 1, 100));
  rc.encode.webp_quality = int(o.integer("webp-quality", 1, 100));
  rc.encode.avif_quality = int(o.integer("avif-quality", 1, 100));
  rc.encode.avif_speed = int(o.integer("avif-speed", 0, 10));
  rc.encode.jxl_quality = int(o.integer("jxl-quality", 1, 100));
  rc.encode.jxl_effort = int(o.integer("jxl-effort", 1, 9));
  rc.iiif.max_width = int(o.integer("iiif-max-width", 1, 65535));
  rc.iiif.max_height = int(o.integer("iiif-max-height", 1, 65535));
  rc.iiif.max_area = o.integer("iiif-max-area", 1, 1LL << 32);
  rc.dzi.tile_size = int(o.integer("dzi-tile-size", 64, 2048));
  rc.dzi.overlap = int(o.integer("dzi-overlap", 0, 8));
  rc.cache_max_age = int(o.integer("cache-max-age", 0, 365 * 86400));
  rc.failure_cache_window = std::chrono::milliseconds(o.integer("failure-cache-ms", 0, 3'600'000));
  rc.compute_hook = compute_hook();
  rc.public_url = o.str("public-url");
  while (!rc.public_url.empty() && rc.public_url.back() == '/') rc.public_url.pop_back();
  const AnalysisSettings analysis = analysis_settings(o);
  rc.ingest = ingest_options(o, analysis.significance);
  rc.significance = analysis.significance;
  rc.analysis_threads = int(o.integer("analysis-threads", 1, 64));
  if (!o.str("signing-key").empty())
    rc.url_signer = std::make_shared<const api::UrlSigner>(api::UrlSigner::from_file(o.str("signing-key")));
  rc.log = [](std::string_view level, std::string_view msg, const nlohmann::json& fields) {
    log_event(level, msg, fields);
  };
  *face_detection = analysis.face_detection;
  return rc;
}

// --workers and --queue: the pool answering computed requests; --ingest-workers and --ingest-queue:
// the one ingesting uploads.
struct PoolSizes {
  int workers = 0;
  std::size_t queue = 0;
  int ingest_workers = 0;
  std::size_t ingest_queue = 0;
};

PoolSizes pool_sizes(const Options& o) {
  PoolSizes p;
  p.workers = int(o.integer("workers", 1, 256));
  p.queue = std::size_t(o.integer("queue", 1, 1 << 20));
  p.ingest_workers = int(o.integer("ingest-workers", 1, 64));
  p.ingest_queue = std::size_t(o.integer("ingest-queue", 0, 1 << 10));
  return p;
}

// The pool ingesting uploads. Uploads are admitted against `upload_slots`; the pool's queue also
// counts a job handed to a thread that has not picked it up yet, so it gets room for every slot
// and never refuses one. An ingest runs on --ingest-threads threads (started by its pool thread,
// so they inherit its priority), ten nice levels below the request workers: on an idle machine it
// takes every core, under request load it yields to the requests instead of halving their CPU.
WorkerPool ingest_pool(int ingest_workers, std::size_t upload_slots) {
  constexpr int kIngestNice = 10;
  return WorkerPool(ingest_workers, upload_slots, kIngestNice);
}

// What /metrics samples at each scrape besides the request counts: the caches, the worker pools,
// the warp engines' analyses and the tiles sent as stored. The sampler keeps references to the
// objects passed, which must outlive `metrics`.
void add_sampled_metrics(Metrics& metrics, api::Router& router, const tiles::PyramidReader& reader,
                         const WorkerPool& cpu, const WorkerPool& ingest, std::size_t warp_cache_limit) {
  metrics.add_sampler([&router, &reader, &cpu, &ingest, warp_cache_limit] {
    using S = Metrics::Sample;
    auto rs = router.response_cache_stats();
    auto ts = reader.stats();
    return std::vector<S>{
        {"zoomwarp_cache_hits_total", "Cache hits.", "counter", R"(cache="response")", double(rs.hits)},
        // OpenImageIO counts one lookup per call but may read several tiles in it: clamp at 0.
        {"zoomwarp_cache_hits_total", "", "counter", R"(cache="tile")", double(std::max<std::int64_t>(0, ts.lookups - ts.tiles_read))},
        {"zoomwarp_cache_misses_total", "Cache misses.", "counter", R"(cache="response")", double(rs.misses)},
        {"zoomwarp_cache_misses_total", "", "counter", R"(cache="tile")", double(ts.tiles_read)},
        {"zoomwarp_cache_bytes", "Bytes held by a cache.", "gauge", R"(cache="response")", double(rs.bytes)},
        {"zoomwarp_cache_bytes", "", "gauge", R"(cache="tile")", double(ts.bytes_used)},
        {"zoomwarp_cache_bytes", "", "gauge", R"(cache="warp")", double(router.warp_cache_bytes())},
        {"zoomwarp_cache_bytes", "", "gauge", R"(cache="failure")", double(router.failure_cache_bytes())},
        {"zoomwarp_cache_limit_bytes", "Byte limit of a cache.", "gauge", R"(cache="response")", double(rs.max_bytes)},
        {"zoomwarp_cache_limit_bytes", "", "gauge", R"(cache="tile")", double(ts.bytes_limit)},
        {"zoomwarp_cache_limit_bytes", "", "gauge", R"(cache="warp")", double(warp_cache_limit)},
        {"zoomwarp_queue_depth", "Jobs waiting for a worker.", "gauge", R"(pool="cpu")", double(cpu.queued())},
        {"zoomwarp_queue_depth", "", "gauge", R"(pool="ingest")", double(ingest.queued())},
        {"zoomwarp_workers_busy", "Workers running a job.", "gauge", R"(pool="cpu")", double(cpu.running())},
        {"zoomwarp_workers_busy", "", "gauge", R"(pool="ingest")", double(ingest.running())},
        {"zoomwarp_worker_jobs_total", "Jobs handed to a worker pool.", "counter", R"(pool="cpu")", double(cpu.accepted())},
        {"zoomwarp_worker_jobs_total", "", "counter", R"(pool="ingest")", double(ingest.accepted())},
        {"zoomwarp_analyses_total", "Warp engines loaded: their analysis computed here (first use) or read from the store.",
         "counter", R"(source="computed")", double(router.analysis_counts().computed)},
        {"zoomwarp_analyses_total", "", "counter", R"(source="read")", double(router.analysis_counts().read)},
        {"zoomwarp_analyses_pending", "Background computations (analyses, warps for a new screen) queued or running.",
         "gauge", "", double(router.analysis_counts().pending)},
        {"zoomwarp_tiles_passthrough_total", "Tile answers computed by sending a stored JPEG tile as it is, without decoding.",
         "counter", "", double(router.tiles_passed_through())},
    };
  });
}

// The server made from the flags, run until a signal stops it; its exit code.
int serve(const Options& o) {
  HttpServerOptions http = http_server_options(o);
  api::RouterConfig rc = router_config(o, &http.face_detection);
  const std::unique_ptr<api::KeyRing> keys = access_settings(o, rc.access);
  if (keys) http.on_reload = [&keys] { keys->reload(); };
  const std::uint64_t tile_cache = o.bytes("tile-cache", 1ULL << 20, 1ULL << 40);
  const PoolSizes pools = pool_sizes(o);
  http.upload_slots = std::size_t(pools.ingest_workers) + pools.ingest_queue;

  tiles::Store store(o.str("store"), std::chrono::milliseconds(o.integer("store-recheck-ms", 0, 3'600'000)),
                     bucket_store_options(o));
  const int removed = store.collect_garbage(http.gc_grace);
  tiles::PyramidReader reader(tile_cache);
  api::Router router(store, reader, rc);
  WorkerPool cpu(pools.workers, pools.queue);
  WorkerPool ingest = ingest_pool(pools.ingest_workers, http.upload_slots);
  Metrics metrics;
  add_sampled_metrics(metrics, router, reader, cpu, ingest, rc.warp_cache_bytes);
  log_event("info", "starting", {{"store", store.root()}, {"workers", pools.workers}, {"tile_cache", tile_cache},
                                 {"response_cache", rc.response_cache_bytes}, {"warp_cache", rc.warp_cache_bytes},
                                 {"gc_removed", removed}});
  HttpServer server(http, store, router, cpu, ingest, metrics);
  const int code = server.run();
  // After a drain that timed out, workers may still be in work that checks no token and hold
  // sessions of the stopped server: leave without waiting for them or destroying what they use.
  // The store survives this (it survives SIGKILL); only their answers are lost.
  // The same for an analysis still running in the background: it is kept only once finished.
  if (cpu.running() + cpu.queued() + ingest.running() + ingest.queued() + router.analysis_counts().pending > 0)
    std::_Exit(code);
  return code;
}

}  // namespace

int serve_command(const std::vector<std::string>& args) {
  return run_command(
      "serve",
      [&]() -> int {
        Options o(serve_specs(), args);
        if (o.help_requested()) {
          std::printf("usage: zoomwarp serve [OPTIONS]\n\nServes the image store over HTTP.\n\n%s", o.usage().c_str());
          return 0;
        }
        if (!o.positionals().empty()) throw std::invalid_argument("unexpected argument '" + o.positionals()[0] + "'");
        return serve(o);
      },
      // Not "zoomwarp serve: what" on stderr: what stops a server belongs in its JSON log.
      [](const std::exception& e) { log_event("error", "cannot serve", {{"error", e.what()}}); });
}

}  // namespace zoomwarp::server
