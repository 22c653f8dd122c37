// Bytes of a bucket's immutable objects kept near the process (issue 29): whole small objects
// (manifests, analyses) and blocks of level files (tiff headers, tile indexes, tiles), in a
// byte-bounded LRU in memory and, optionally, in a bounded folder on local disk below it
// (`zoomwarp serve --store-cache DIR --store-cache-bytes N`). Keys name an object and a range of
// it; the bytes under a key never change (versions are immutable), so nothing is ever invalidated,
// only evicted.
//
// The folder: one file per key (named by the key's SHA-256), written under a temporary name and
// renamed, so a reader never sees a part of one. What it held when the process started is used
// again (a restarted replica starts warm), oldest first evicted. Its bound is this process's:
// processes sharing one folder each keep their own account, and a file another one evicted is
// simply a miss.
//
// Thread safety: every member may be called from any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace zoomwarp::tiles {

struct RangeCacheOptions {
  std::size_t memory_bytes = 256u << 20;
  std::string disk_dir;          // empty: memory only
  std::uint64_t disk_bytes = 0;  // the folder's bound (with disk_dir)
};

struct RangeCacheStats {
  std::uint64_t memory_hits = 0, disk_hits = 0, misses = 0;
  std::uint64_t memory_bytes = 0, memory_limit = 0;
  std::uint64_t disk_bytes = 0, disk_limit = 0, disk_files = 0, disk_evictions = 0;
};

class RangeCache {
 public:
  // Throws std::runtime_error when disk_dir cannot be made.
  explicit RangeCache(RangeCacheOptions options);
  ~RangeCache();

  // The bytes under `key`, from memory, else from the folder (then kept in memory too), else null.
  std::shared_ptr<const std::string> find(const std::string& key);
  // Keeps `bytes` under `key`, in memory and in the folder. A value too large for a tier (over an
  // eighth of its bound) is not kept there. A folder that cannot be written is only not used.
  void insert(const std::string& key, std::shared_ptr<const std::string> bytes);

  RangeCacheStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace zoomwarp::tiles
