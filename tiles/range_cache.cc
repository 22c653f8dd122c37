#include "tiles/range_cache.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <list>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include "tiles/byte_lru_cache.h"
#include "tiles/source_digest.h"

namespace zoomwarp::tiles {

namespace fs = std::filesystem;

namespace {

// Bytes the folder's file system spends beyond a file's length, counted against the bound.
constexpr std::uint64_t kFileOverhead = 4096;

std::optional<std::string> read_whole(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) return std::nullopt;
  return s.str();
}

// The folder tier: files under dir/ranges/XY/HASH, an LRU account of them.
class DiskTier {
 public:
  DiskTier(fs::path dir, std::uint64_t limit) : root_(std::move(dir) / "ranges"), limit_(limit) {
    std::error_code ec;
    fs::create_directories(root_, ec);
    if (ec) throw std::runtime_error("cannot create the store cache " + root_.string() + ": " + ec.message());
    // What an earlier process left: oldest first evicted. Temporaries of writers that are gone
    // (their pid in the name) are removed.
    struct Found {
      fs::file_time_type time;
      std::string hash;
      std::uint64_t bytes;
    };
    std::vector<Found> found;
    for (auto it = fs::recursive_directory_iterator(root_, ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec)) {
      if (!it->is_regular_file(ec)) continue;
      const std::string name = it->path().filename().string();
      if (name.find(".tmp.") != std::string::npos) {
        fs::remove(it->path(), ec);
        ec.clear();
        continue;
      }
      found.push_back(Found{it->last_write_time(ec), name, it->file_size(ec) + kFileOverhead});
    }
    std::sort(found.begin(), found.end(), [](const Found& a, const Found& b) { return a.time > b.time; });
    for (Found& f : found) {
      order_.push_back(Entry{f.hash, f.bytes});
      index_.emplace(f.hash, std::prev(order_.end()));
      bytes_ += f.bytes;
    }
    std::lock_guard lock(mu_);
    evict_over_limit();
  }

  std::optional<std::string> find(const std::string& hash) {
    {
      std::lock_guard lock(mu_);
      auto it = index_.find(hash);
      if (it == index_.end()) return std::nullopt;
      order_.splice(order_.begin(), order_, it->second);
    }
    std::optional<std::string> bytes = read_whole(path(hash));
    if (!bytes) {  // evicted by another process sharing the folder
      std::lock_guard lock(mu_);
      if (auto it = index_.find(hash); it != index_.end()) erase(it->second);
    }
    return bytes;
  }

  void insert(const std::string& hash, const std::string& bytes) {
    const std::uint64_t cost = bytes.size() + kFileOverhead;
    if (cost > limit_ / 8) return;
    {
      std::lock_guard lock(mu_);
      if (index_.count(hash)) return;
    }
    static std::atomic<std::uint64_t> writes{0};
    const fs::path target = path(hash);
    const fs::path tmp = target.string() + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(++writes);
    std::error_code ec;
    fs::create_directories(target.parent_path(), ec);
    {
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      out.write(bytes.data(), std::streamsize(bytes.size()));
      if (!out.flush()) {
        out.close();
        fs::remove(tmp, ec);
        return;  // a full or read-only folder: the memory tier still works
      }
    }
    fs::rename(tmp, target, ec);
    if (ec) {
      fs::remove(tmp, ec);
      return;
    }
    std::lock_guard lock(mu_);
    if (index_.count(hash)) return;
    order_.push_front(Entry{hash, cost});
    index_.emplace(hash, order_.begin());
    bytes_ += cost;
    evict_over_limit();
  }

  void add_stats(RangeCacheStats& s) const {
    std::lock_guard lock(mu_);
    s.disk_bytes = bytes_;
    s.disk_limit = limit_;
    s.disk_files = index_.size();
    s.disk_evictions = evictions_;
  }

 private:
  struct Entry {
    std::string hash;
    std::uint64_t bytes;
  };
  using Iter = std::list<Entry>::iterator;

  fs::path path(const std::string& hash) const { return root_ / hash.substr(0, 2) / hash; }

  void erase(Iter it) {
    bytes_ -= it->bytes;
    index_.erase(it->hash);
    order_.erase(it);
  }

  // Caller holds mu_.
  void evict_over_limit() {
    while (bytes_ > limit_ && !order_.empty()) {
      std::error_code ec;
      fs::remove(path(order_.back().hash), ec);
      erase(std::prev(order_.end()));
      ++evictions_;
    }
  }

  const fs::path root_;
  const std::uint64_t limit_;
  mutable std::mutex mu_;
  std::list<Entry> order_;  // most recently used first
  std::unordered_map<std::string, Iter> index_;
  std::uint64_t bytes_ = 0, evictions_ = 0;
};

}  // namespace

struct RangeCache::Impl {
  explicit Impl(const RangeCacheOptions& o)
      : memory(o.memory_bytes),
        memory_limit(o.memory_bytes),
        disk(o.disk_dir.empty() ? nullptr : std::make_unique<DiskTier>(o.disk_dir, o.disk_bytes)) {}
  ByteLruCache<std::string> memory;
  const std::uint64_t memory_limit;
  const std::unique_ptr<DiskTier> disk;
  std::atomic<std::uint64_t> memory_hits{0}, disk_hits{0}, misses{0};
};

RangeCache::RangeCache(RangeCacheOptions options) : impl_(std::make_unique<Impl>(options)) {}
RangeCache::~RangeCache() = default;

std::shared_ptr<const std::string> RangeCache::find(const std::string& key) {
  if (auto hit = impl_->memory.get(key)) {
    ++impl_->memory_hits;
    return hit;
  }
  if (impl_->disk) {
    if (std::optional<std::string> bytes = impl_->disk->find(sha256_hex(key))) {
      ++impl_->disk_hits;
      auto value = std::make_shared<const std::string>(std::move(*bytes));
      impl_->memory.put(key, value, value->size());
      return value;
    }
  }
  ++impl_->misses;
  return nullptr;
}

void RangeCache::insert(const std::string& key, std::shared_ptr<const std::string> bytes) {
  if (!bytes) return;
  if (impl_->disk) impl_->disk->insert(sha256_hex(key), *bytes);
  impl_->memory.put(key, bytes, bytes->size());
}

RangeCacheStats RangeCache::stats() const {
  RangeCacheStats s;
  s.memory_hits = impl_->memory_hits;
  s.disk_hits = impl_->disk_hits;
  s.misses = impl_->misses;
  const auto m = impl_->memory.stats();
  s.memory_bytes = m.bytes;
  s.memory_limit = impl_->memory_limit;
  if (impl_->disk) impl_->disk->add_stats(s);
  return s;
}

}  // namespace zoomwarp::tiles
