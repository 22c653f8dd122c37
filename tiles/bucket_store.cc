#include "tiles/bucket_store.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <future>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "tiles/store_deadline.h"
#include "tiles/store_errors.h"
#include "tiles/superseded_versions.h"
#include "tiles/unique_names.h"

namespace zoomwarp::tiles {

namespace fs = std::filesystem;

namespace {

// The list of files an edit's staging folder takes from the edited version inside the store
// (BucketStore::copy_into_staging), and the largest object one CopyObject may copy.
constexpr const char* kCopiedList = ".copied-in-store";
constexpr std::uint64_t kMaxCopyBytes = 5ull << 30;

// A store operation's time when the thread has no deadline of its own (StoreDeadlineScope): a
// command's, or work in the background.
constexpr std::chrono::seconds kOperationBudget{30};

S3Deadline deadline() { return StoreDeadlineScope::deadline(kOperationBudget); }

// Runs a request to the store: a store that is down, hung or throttling past the retries is
// StoreUnavailable to the callers above tiles/ (503/504), other failures stay S3Errors.
// What a bucket store and its files share: the client, the cache, the bucket, and whether the
// store failed its last readiness check (BucketStore::problem, every second in a server): requests
// then fail at once instead of each waiting out its deadline, so that workers stay free for what
// the caches can answer. Cleared by the first check the store answers.
struct Bucket {
  std::shared_ptr<S3Client> client;
  std::shared_ptr<RangeCache> cache;
  std::string name;
  mutable std::atomic<bool> down{false};
};

// A thread whose deadline has passed (the server's I/O thread sets one in the past: it must never
// wait for the store) fails at once, without a request; so does every thread while the store is
// known to be down.
template <class F>
auto guarded(const Bucket& bucket, F&& request) -> decltype(request()) {
  if (deadline() <= std::chrono::steady_clock::now())
    throw StoreUnavailable("no time left for a request to the store", true);
  if (bucket.down.load(std::memory_order_relaxed))
    throw StoreUnavailable("the store did not answer its last check", false, true);
  try {
    return request();
  } catch (const S3Error& e) {
    if (e.unavailable()) throw StoreUnavailable(e.what(), e.timed_out());
    throw;
  }
}

// Every key under `prefix`, every page.
std::vector<S3ListEntry> list_all(const Bucket& bucket, const std::string& prefix) {
  std::vector<S3ListEntry> out;
  std::string continuation;
  do {
    S3ListPage page = guarded(bucket, [&] { return bucket.client->list(bucket.name, prefix, "", continuation, deadline()); });
    for (S3ListEntry& e : page.objects) out.push_back(std::move(e));
    continuation = page.truncated ? page.next_continuation : "";
  } while (!continuation.empty());
  return out;
}

// The names one level below `prefix` ("a/" of "PREFIX/a/b"), every page, without their slash.
std::vector<std::string> list_children(const Bucket& bucket, const std::string& prefix) {
  std::vector<std::string> out;
  std::string continuation;
  do {
    S3ListPage page = guarded(bucket, [&] { return bucket.client->list(bucket.name, prefix, "/", continuation, deadline()); });
    for (const S3ListEntry& e : page.objects) out.push_back(e.key.substr(prefix.size()));
    for (const std::string& p : page.common_prefixes) out.push_back(p.substr(prefix.size(), p.size() - prefix.size() - 1));
    continuation = page.truncated ? page.next_continuation : "";
  } while (!continuation.empty());
  return out;
}


// Blocks of a level file: what one cache entry holds. A tile (tens of kB) is one or two blocks, a
// TIFF header and tile index a few; a read wanting several missing blocks in a row fetches them
// with one ranged GET.
constexpr std::uint64_t kBlockBytes = 32u << 10;
// Reads this large (store copy, an edit's staging) go straight to the store: they would only
// flush the cache.
constexpr std::size_t kDirectReadBytes = 1u << 20;

class BucketObject final : public RandomAccessFile {
 public:
  BucketObject(std::shared_ptr<const Bucket> bucket, std::string key, std::uint64_t size)
      : bucket_(std::move(bucket)), key_(std::move(key)), size_(size), name_("s3://" + bucket_->name + "/" + key_) {}

  std::uint64_t size() const override { return size_; }
  const std::string& name() const override { return name_; }

  std::size_t read(std::uint64_t offset, std::size_t n, char* dst) const override {
    if (offset >= size_ || n == 0) return 0;
    n = std::size_t(std::min<std::uint64_t>(n, size_ - offset));
    if (n >= kDirectReadBytes) {
      const std::string bytes = fetch(offset, n);
      std::copy(bytes.begin(), bytes.end(), dst);
      return n;
    }
    const std::uint64_t first = offset / kBlockBytes, last = (offset + n - 1) / kBlockBytes;
    std::vector<std::shared_ptr<const std::string>> blocks(last - first + 1);
    for (std::uint64_t b = first; b <= last; ++b) blocks[b - first] = bucket_->cache->find(block_key(b));
    for (std::uint64_t b = first; b <= last;) {
      if (blocks[b - first]) {
        ++b;
        continue;
      }
      std::uint64_t end = b;  // the run of missing blocks [b, end]
      while (end + 1 <= last && !blocks[end + 1 - first]) ++end;
      std::vector<std::shared_ptr<const std::string>> run = fetch_blocks(b, end);
      for (std::uint64_t k = b; k <= end; ++k) blocks[k - first] = std::move(run[k - b]);
      b = end + 1;
    }
    std::size_t done = 0;
    for (std::uint64_t b = first; b <= last; ++b) {
      const std::string& block = *blocks[b - first];
      const std::uint64_t start = b == first ? offset - b * kBlockBytes : 0;
      const std::size_t take = std::min<std::size_t>(n - done, block.size() - start);
      std::copy_n(block.data() + start, take, dst + done);
      done += take;
    }
    return done;
  }

  bool prefetch(const std::vector<ByteRange>& ranges) const override {
    // The blocks not held, as runs of consecutive blocks: one ranged GET each, all at once.
    std::set<std::uint64_t> missing;
    for (const ByteRange& r : ranges) {
      if (r.length == 0 || r.offset >= size_) continue;
      const std::uint64_t last = std::min(size_, r.offset + r.length) - 1;
      for (std::uint64_t b = r.offset / kBlockBytes; b <= last / kBlockBytes; ++b)
        if (!missing.count(b) && !bucket_->cache->find(block_key(b))) missing.insert(b);
    }
    std::vector<std::pair<std::uint64_t, std::uint64_t>> runs;
    for (std::uint64_t b : missing) {
      if (!runs.empty() && runs.back().second + 1 == b) runs.back().second = b;
      else runs.emplace_back(b, b);
    }
    if (runs.size() > kMaxPrefetchRuns) runs.resize(kMaxPrefetchRuns);
    std::vector<std::future<void>> others;
    const S3Deadline until = deadline();  // this thread's: the helpers end with the request
    for (std::size_t i = 1; i < runs.size(); ++i)
      others.push_back(std::async(std::launch::async, [this, r = runs[i], until] {
        const StoreDeadlineScope scope(until);
        fetch_blocks(r.first, r.second);
      }));
    bool held = true;
    try {
      if (!runs.empty()) fetch_blocks(runs[0].first, runs[0].second);
    } catch (const std::exception&) {  // the read that follows asks again, and reports it
      held = false;
    }
    for (auto& f : others) {
      try {
        f.get();
      } catch (const std::exception&) {
        held = false;
      }
    }
    return held;
  }

 private:
  // Prefetches at once no more than this many runs (threads): a region of a level is a few
  // rows of stored tiles.
  static constexpr std::size_t kMaxPrefetchRuns = 8;

  std::string block_key(std::uint64_t b) const { return name_ + "#" + std::to_string(b); }

  // Blocks [first, last] fetched with one ranged GET and kept in the cache.
  std::vector<std::shared_ptr<const std::string>> fetch_blocks(std::uint64_t first, std::uint64_t last) const {
    const std::uint64_t from = first * kBlockBytes, to = std::min(size_, (last + 1) * kBlockBytes);
    const std::string run = fetch(from, std::size_t(to - from));
    std::vector<std::shared_ptr<const std::string>> blocks;
    for (std::uint64_t k = first; k <= last; ++k) {
      auto block = std::make_shared<const std::string>(run.substr((k - first) * kBlockBytes, kBlockBytes));
      bucket_->cache->insert(block_key(k), block);
      blocks.push_back(std::move(block));
    }
    return blocks;
  }

  std::string fetch(std::uint64_t offset, std::size_t n) const {
    std::optional<std::string> bytes =
        guarded(*bucket_, [&] { return bucket_->client->get_range(bucket_->name, key_, offset, n, deadline()); });
    if (!bytes) throw std::runtime_error(name_ + " vanished while being read");
    return std::move(*bytes);
  }

  const std::shared_ptr<const Bucket> bucket_;
  const std::string key_;
  const std::uint64_t size_;
  const std::string name_;
};

class BucketFiles final : public VersionFiles {
 public:
  BucketFiles(std::shared_ptr<const Bucket> bucket, std::string key_prefix)
      : bucket_(std::move(bucket)),
        key_prefix_(std::move(key_prefix)),
        location_("s3://" + bucket_->name + "/" + key_prefix_.substr(0, key_prefix_.size() - 1)) {}

  std::optional<std::string> read(const std::string& name) const override {
    const std::string key = location_ + "/" + name;
    if (auto cached = bucket_->cache->find(key)) return *cached;
    std::optional<std::string> bytes = guarded(*bucket_, [&] { return client().get(bucket_->name, key_prefix_ + name, deadline()); });
    if (bytes) {
      bucket_->cache->insert(key, std::make_shared<const std::string>(*bytes));
      remember_size(name, bytes->size());
    }
    return bytes;
  }

  bool exists(const std::string& name) const override { return size_of(name).has_value(); }

  void write(const std::string& name, const std::string& bytes) const override {
    guarded(*bucket_, [&] { return client().put(bucket_->name, key_prefix_ + name, bytes, "application/octet-stream", deadline()); });
    bucket_->cache->insert(location_ + "/" + name, std::make_shared<const std::string>(bytes));
    remember_size(name, bytes.size());
  }

  std::vector<std::string> names() const override {
    std::vector<std::string> out;
    for (const S3ListEntry& e : list_all(*bucket_, key_prefix_)) out.push_back(e.key.substr(key_prefix_.size()));
    return out;
  }

  std::shared_ptr<const RandomAccessFile> open(const std::string& name) const override {
    const std::optional<std::uint64_t> size = size_of(name);
    if (!size) return nullptr;
    return std::make_shared<BucketObject>(bucket_, key_prefix_ + name, *size);
  }

  std::optional<std::string> local_path(const std::string&) const override { return std::nullopt; }

  const std::string& location() const override { return location_; }

 private:
  S3Client& client() const { return *bucket_->client; }

  // A file's size: a HEAD the first time, then remembered (a version's files never change, and
  // one once there stays while the version is readable). A missing file is asked again each time:
  // another replica may add it (an analysis).
  std::optional<std::uint64_t> size_of(const std::string& name) const {
    {
      std::lock_guard lock(mu_);
      if (auto it = sizes_.find(name); it != sizes_.end()) return it->second;
    }
    const std::optional<S3ObjectInfo> info = guarded(*bucket_, [&] { return client().head(bucket_->name, key_prefix_ + name, deadline()); });
    if (!info) return std::nullopt;
    remember_size(name, info->size);
    return info->size;
  }

  void remember_size(const std::string& name, std::uint64_t size) const {
    std::lock_guard lock(mu_);
    sizes_[name] = size;
  }

  const std::shared_ptr<const Bucket> bucket_;
  const std::string key_prefix_;
  const std::string location_;
  mutable std::mutex mu_;
  mutable std::map<std::string, std::uint64_t> sizes_;
};

class BucketStore final : public StoreBackend {
 public:
  BucketStore(const S3Location& where, std::shared_ptr<S3Client> client, const std::string& local_dir,
              const RangeCacheOptions& cache, const LeaseTiming& lease)
      : bucket_(make_bucket(client, cache, where.bucket)),
        client_(std::move(client)),
        where_(where),
        location_(where.url()),
        staging_(fs::path(local_dir) / "staging"),
        lease_(lease) {
    std::error_code ec;
    fs::create_directories(staging_, ec);
    if (ec) throw std::runtime_error("cannot create the store's local folder " + staging_.string() + ": " + ec.message());
  }

  const std::string& location() const override { return location_; }

  std::optional<std::string> read_pointer(const std::string& id) const override {
    const std::optional<std::string> body = guarded(*bucket_, [&] { return client_->get(where_.bucket, pointer_key(id), deadline()); });
    if (!body) return std::nullopt;
    std::string v = *body;
    while (!v.empty() && (v.back() == '\n' || v.back() == ' ')) v.pop_back();
    if (!v.starts_with(id + "@") || v.find('/') != std::string::npos) return std::nullopt;
    return v;
  }

  bool has_pointer(const std::string& id) const override {
    return guarded(*bucket_, [&] { return client_->head(where_.bucket, pointer_key(id), deadline()); }).has_value();
  }

  std::vector<std::string> pointer_ids() const override {
    return list_children(*bucket_, where_.prefix + "images/");
  }

  std::shared_ptr<const VersionFiles> version_files(const std::string& version_dir) const override {
    return std::make_shared<BucketFiles>(bucket_, version_prefix(version_dir));
  }

  std::string make_staging_dir() const override {
    const fs::path p = staging_ / owned_unique_name();
    fs::create_directories(p);
    return p.string();
  }

  void discard_staging(const std::string& staging_dir) const override {
    std::error_code ec;
    fs::remove_all(staging_dir, ec);
  }

  // An edit's new version takes the files it does not change from the version it edits by a copy
  // inside the store (CopyObject), not through this host: a label edit of a gigapixel image moved
  // its whole pyramid down and up again. The staging folder holds their list (kCopiedList,
  // "NAME\tKEY" a line), which store_version() copies from unless the edit wrote a file of that
  // name. Files over S3's 5 GiB copy limit are brought down as before.
  void copy_into_staging(const std::string& version_dir, const std::string& staging) const override {
    const auto files = version_files(version_dir);
    const std::string prefix = version_prefix(version_dir);
    std::string copied;
    for (const S3ListEntry& e : list_all(*bucket_, prefix)) {
      const std::string name = e.key.substr(prefix.size());
      if (name == "manifest.json" || name.find('/') != std::string::npos || name == kCopiedList) continue;
      if (e.size <= kMaxCopyBytes) {
        copied += name + "\t" + e.key + "\n";
        continue;
      }
      const std::shared_ptr<const RandomAccessFile> file = files->open(name);
      if (!file) throw std::runtime_error(location_ + ": " + version_dir + "/" + name + " vanished while being copied");
      copy_to_local_file(*file, (fs::path(staging) / name).string());
    }
    if (!copied.empty()) folder_files(staging)->write(kCopiedList, copied);
  }

  std::shared_ptr<void> lock_id(const std::string& id) override {
    std::shared_ptr<std::mutex> mu;
    {
      std::lock_guard lock(locks_mu_);
      auto& slot = locks_[id];
      if (!slot) slot = std::make_shared<std::mutex>();
      mu = slot;
    }
    std::unique_lock own(*mu);
    const LeaseObject lease = lease_object(id);
    HeldLease held;
    try {
      held = guarded(*bucket_, [&] { return acquire_lease(lease, lease_, deadline()); });
    } catch (const LeaseBusy& e) {
      throw StoreUnavailable("image " + id + " is being changed by another replica (" + e.what() + ")", true);
    }
    {
      std::lock_guard lock(locks_mu_);
      held_[id] = held;
    }
    own.release();
    return std::shared_ptr<void>(mu.get(), [this, mu, id, lease, held](void*) {
      {
        std::lock_guard lock(locks_mu_);
        held_.erase(id);
      }
      release_lease(lease, held, lease_);
      mu->unlock();
    });
  }

  void store_version(const std::string& staging_dir, const std::string& version_dir) override {
    const std::string prefix = version_prefix(version_dir);
    try {
      // Every file the staging folder holds is the version's, in name order (the same order on
      // every try), manifest.json last: a version is read by its manifest.
      std::vector<fs::path> files;
      for (const auto& e : fs::directory_iterator(staging_dir))
        if (!e.is_directory() && e.path().filename() != "manifest.json" && e.path().filename() != kCopiedList)
          files.push_back(e.path());
      std::sort(files.begin(), files.end());
      // The files taken from the edited version, copied inside the store (copy_into_staging).
      if (const auto copied = folder_files(staging_dir)->read(kCopiedList)) {
        std::istringstream lines(*copied);
        for (std::string line; std::getline(lines, line);) {
          const std::size_t tab = line.find('\t');
          if (tab == std::string::npos) continue;
          const std::string name = line.substr(0, tab), from = line.substr(tab + 1);
          if (fs::exists(fs::path(staging_dir) / name)) continue;  // the edit wrote its own
          guarded(*bucket_, [&] { return client_->copy(where_.bucket, from, prefix + name, deadline()); });
        }
      }
      files.push_back(fs::path(staging_dir) / "manifest.json");
      for (const fs::path& f : files)
        guarded(*bucket_, [&] {
          return client_->put_file(where_.bucket, prefix + f.filename().string(), f.string(), "application/octet-stream",
                                   deadline());
        });
    } catch (...) {
      discard_staging(staging_dir);
      throw;
    }
    discard_staging(staging_dir);
  }

  void point(const std::string& id, const std::string& version_dir) override {
    mark_unpublished(id, version_dir);
    // The pointer is written only while the lease surely is ours (bucket_lease.h).
    if (lease_left(id) <= std::chrono::milliseconds(0))
      throw StoreUnavailable("the lease on image " + id + " ran out before its pointer was written; nothing changed", true);
    guarded(*bucket_, [&] { return client_->put(where_.bucket, pointer_key(id), version_dir + "\n", "text/plain", deadline()); });
  }

  bool remove_pointer(const std::string& id) override {
    if (!has_pointer(id)) return false;
    mark_unpublished(id, "");
    if (lease_left(id) <= std::chrono::milliseconds(0))
      throw StoreUnavailable("the lease on image " + id + " ran out before its pointer was removed; nothing changed", true);
    guarded(*bucket_, [&] { client_->remove(where_.bucket, pointer_key(id), deadline()); });
    return true;
  }

  int collect_garbage(std::chrono::seconds grace, const std::function<void(const std::string&)>& removed_version) override {
    std::set<std::string> live;
    for (const std::string& id : pointer_ids())
      if (auto v = read_pointer(id)) live.insert(*v);
    const std::int64_t now_ms = unix_ms_now();
    int removed = 0;
    // By supersede time (superseded_versions.h): a version unnamed for the grace goes.
    std::set<std::string> versions;
    for (std::string& version_dir : list_children(*bucket_, where_.prefix + "versions/")) {
      versions.insert(version_dir);
      const bool named = live.count(version_dir) > 0;
      const std::optional<std::int64_t> mark = named ? std::nullopt : read_mark(version_dir);
      switch (collect_verdict(named, mark, created_ms(version_dir), now_ms, grace)) {
        case Collect::kKeep:
          break;
        case Collect::kMark:
          write_mark(version_dir, now_ms);
          break;
        case Collect::kRemove:
          for (const S3ListEntry& e : list_all(*bucket_, version_prefix(version_dir)))
            guarded(*bucket_, [&] { client_->remove(where_.bucket, e.key, deadline()); });
          guarded(*bucket_, [&] { client_->remove(where_.bucket, mark_key(version_dir), deadline()); });
          removed_version(version_dir);
          ++removed;
          break;
      }
    }
    // Marks of versions named again (a mark written before a pointer move that then failed) or gone.
    for (const std::string& marked : list_children(*bucket_, where_.prefix + kSupersededFolder + "/"))
      if (live.count(marked) || !versions.count(marked))
        guarded(*bucket_, [&] { client_->remove(where_.bucket, mark_key(marked), deadline()); });
    // Staging folders of this host's processes that are gone.
    const std::string me = host_name() + ".";
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(staging_, ec)) {
      const std::string name = e.path().filename().string();
      if (!name.starts_with(me)) continue;
      const std::string pid = name.substr(me.size(), name.find('.', me.size()) - me.size());
      if (pid.empty() || pid == std::to_string(::getpid()) || fs::exists("/proc/" + pid)) continue;
      std::error_code rec;
      fs::remove_all(e.path(), rec);
      if (!rec) ++removed;
    }
    return removed;
  }

  std::string problem(std::chrono::milliseconds within) const override {
    try {
      client_->list(where_.bucket, where_.prefix + "images/", "/", "", std::chrono::steady_clock::now() + within, 1);
      bucket_->down = false;
      return "";
    } catch (const S3Error& e) {
      bucket_->down = e.unavailable();
      return e.what();
    } catch (const std::exception& e) {
      return e.what();
    }
  }

  StoreStats stats() const override { return StoreStats{true, client_->stats(), bucket_->cache->stats()}; }

 private:
  static std::shared_ptr<const Bucket> make_bucket(std::shared_ptr<S3Client> client, const RangeCacheOptions& cache,
                                                   const std::string& name) {
    auto b = std::make_shared<Bucket>();
    b->client = std::move(client);
    b->cache = std::make_shared<RangeCache>(cache);
    b->name = name;
    return b;
  }

  std::string pointer_key(const std::string& id) const { return where_.prefix + "images/" + id; }
  LeaseObject lease_object(const std::string& id) const {
    const std::string key = where_.prefix + "locks/" + id;
    return LeaseObject{[this, key] { return client_->get(where_.bucket, key, deadline()); },
                       [this, key](const std::string& text) { client_->put(where_.bucket, key, text, "text/plain", deadline()); },
                       [this, key] { client_->remove(where_.bucket, key, deadline()); }};
  }
  // How long this process may still move images/ID under its lease (none held: zero).
  std::chrono::milliseconds lease_left(const std::string& id) const {
    std::lock_guard lock(locks_mu_);
    const auto it = held_.find(id);
    return it == held_.end() ? std::chrono::milliseconds(0) : lease_time_left(it->second, lease_);
  }
  std::string mark_key(const std::string& version_dir) const {
    return where_.prefix + kSupersededFolder + "/" + version_dir;
  }
  std::optional<std::int64_t> read_mark(const std::string& version_dir) const {
    const std::optional<std::string> body =
        guarded(*bucket_, [&] { return client_->get(where_.bucket, mark_key(version_dir), deadline()); });
    return body ? parse_superseded_mark(*body) : std::nullopt;
  }
  void write_mark(const std::string& version_dir, std::int64_t unix_ms) const {
    guarded(*bucket_, [&] {
      return client_->put(where_.bucket, mark_key(version_dir), superseded_mark(unix_ms), "text/plain", deadline());
    });
  }
  // Before images/ID moves to `next` (or away, for ""): the version it names now is superseded now.
  void mark_unpublished(const std::string& id, const std::string& next) const {
    if (const std::optional<std::string> now = read_pointer(id); now && *now != next) write_mark(*now, unix_ms_now());
  }
  std::string version_prefix(const std::string& version_dir) const {
    return where_.prefix + "versions/" + version_dir + "/";
  }

  // ID@VERSION's creation time: VERSION's first 11 hex digits (Store::publish), or nullopt for a
  // name that is not a version's.
  static std::optional<std::int64_t> created_ms(const std::string& version_dir) {
    const std::size_t at = version_dir.rfind('@');
    if (at == std::string::npos || version_dir.size() < at + 12) return std::nullopt;
    std::int64_t ms = 0;
    for (std::size_t i = at + 1; i < at + 12; ++i) {
      const char c = version_dir[i];
      const int d = c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
      if (d < 0) return std::nullopt;
      ms = ms * 16 + d;
    }
    return ms;
  }

  const std::shared_ptr<const Bucket> bucket_;
  const std::shared_ptr<S3Client> client_;
  const S3Location where_;
  const std::string location_;
  const fs::path staging_;
  const LeaseTiming lease_;
  mutable std::mutex locks_mu_;
  std::map<std::string, std::shared_ptr<std::mutex>> locks_;
  std::map<std::string, HeldLease> held_;  // the leases this process holds, by id
};

}  // namespace

std::unique_ptr<StoreBackend> bucket_store(const S3Location& where, std::shared_ptr<S3Client> client,
                                           const std::string& local_dir, const RangeCacheOptions& cache,
                                           const LeaseTiming& lease) {
  return std::make_unique<BucketStore>(where, std::move(client), local_dir, cache, lease);
}

}  // namespace zoomwarp::tiles
