#include "tiles/bucket_store.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "tiles/unique_names.h"

namespace zoomwarp::tiles {

namespace fs = std::filesystem;

namespace {

// Every store operation's time: the Store's callers have no deadline of their own to pass down.
constexpr std::chrono::seconds kOperationBudget{30};

S3Deadline deadline() { return std::chrono::steady_clock::now() + kOperationBudget; }

std::optional<std::string> read_local(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A mirror file written whole under a temporary name of this writer's own, then renamed: readers
// of the mirror, in this process or another sharing it, never see a part of it.
void write_local(const fs::path& path, std::string_view bytes) {
  static std::atomic<std::uint64_t> writes{0};
  fs::create_directories(path.parent_path());
  const fs::path tmp = path.string() + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(++writes);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    if (!out.flush()) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw std::runtime_error("cannot write " + tmp.string());
    }
  }
  fs::rename(tmp, path);
}

// Every key under `prefix`, every page.
std::vector<S3ListEntry> list_all(S3Client& client, const std::string& bucket, const std::string& prefix) {
  std::vector<S3ListEntry> out;
  std::string continuation;
  do {
    S3ListPage page = client.list(bucket, prefix, "", continuation, deadline());
    for (S3ListEntry& e : page.objects) out.push_back(std::move(e));
    continuation = page.truncated ? page.next_continuation : "";
  } while (!continuation.empty());
  return out;
}

// The names one level below `prefix` ("a/" of "PREFIX/a/b"), every page, without their slash.
std::vector<std::string> list_children(S3Client& client, const std::string& bucket, const std::string& prefix) {
  std::vector<std::string> out;
  std::string continuation;
  do {
    S3ListPage page = client.list(bucket, prefix, "/", continuation, deadline());
    for (const S3ListEntry& e : page.objects) out.push_back(e.key.substr(prefix.size()));
    for (const std::string& p : page.common_prefixes) out.push_back(p.substr(prefix.size(), p.size() - prefix.size() - 1));
    continuation = page.truncated ? page.next_continuation : "";
  } while (!continuation.empty());
  return out;
}

class BucketFiles final : public VersionFiles {
 public:
  BucketFiles(std::shared_ptr<S3Client> client, std::string bucket, std::string key_prefix, fs::path mirror)
      : client_(std::move(client)),
        bucket_(std::move(bucket)),
        key_prefix_(std::move(key_prefix)),
        mirror_(std::move(mirror)),
        location_("s3://" + bucket_ + "/" + key_prefix_.substr(0, key_prefix_.size() - 1)) {}

  std::optional<std::string> read(const std::string& name) const override {
    if (auto local = read_local(mirror_ / name)) return local;
    std::optional<std::string> bytes = client_->get(bucket_, key_prefix_ + name, deadline());
    if (bytes) write_local(mirror_ / name, *bytes);
    return bytes;
  }

  bool exists(const std::string& name) const override {
    std::error_code ec;
    return fs::exists(mirror_ / name, ec) || client_->head(bucket_, key_prefix_ + name, deadline()).has_value();
  }

  void write(const std::string& name, const std::string& bytes) const override {
    client_->put(bucket_, key_prefix_ + name, bytes, "application/octet-stream", deadline());
    write_local(mirror_ / name, bytes);
  }

  std::vector<std::string> names() const override {
    std::vector<std::string> out;
    for (const S3ListEntry& e : list_all(*client_, bucket_, key_prefix_)) out.push_back(e.key.substr(key_prefix_.size()));
    return out;
  }

  // Fetched whole into the mirror on first use; a missing object leaves the path missing, so the
  // reader opening it says so.
  std::optional<std::string> local_path(const std::string& name) const override {
    const fs::path path = mirror_ / name;
    std::error_code ec;
    if (!fs::exists(path, ec)) read(name);
    return path.string();
  }

  const std::string& location() const override { return location_; }

 private:
  const std::shared_ptr<S3Client> client_;
  const std::string bucket_, key_prefix_;
  const fs::path mirror_;
  const std::string location_;
};

class BucketStore final : public StoreBackend {
 public:
  BucketStore(const S3Location& where, std::shared_ptr<S3Client> client, const std::string& cache_dir)
      : client_(std::move(client)), where_(where), location_(where.url()), cache_(cache_dir) {
    std::error_code ec;
    fs::create_directories(cache_ / "staging", ec);
    fs::create_directories(cache_ / "versions", ec);
    if (ec) throw std::runtime_error("cannot create the store's local folder " + cache_.string() + ": " + ec.message());
  }

  const std::string& location() const override { return location_; }

  std::optional<std::string> read_pointer(const std::string& id) const override {
    const std::optional<std::string> body = client_->get(where_.bucket, pointer_key(id), deadline());
    if (!body) return std::nullopt;
    std::string v = *body;
    while (!v.empty() && (v.back() == '\n' || v.back() == ' ')) v.pop_back();
    if (!v.starts_with(id + "@") || v.find('/') != std::string::npos) return std::nullopt;
    return v;
  }

  bool has_pointer(const std::string& id) const override {
    return client_->head(where_.bucket, pointer_key(id), deadline()).has_value();
  }

  std::vector<std::string> pointer_ids() const override {
    return list_children(*client_, where_.bucket, where_.prefix + "images/");
  }

  std::shared_ptr<const VersionFiles> version_files(const std::string& version_dir) const override {
    return std::make_shared<BucketFiles>(client_, where_.bucket, version_prefix(version_dir), cache_ / "versions" / version_dir);
  }

  std::string make_staging_dir() const override {
    const fs::path p = cache_ / "staging" / owned_unique_name();
    fs::create_directories(p);
    return p.string();
  }

  void discard_staging(const std::string& staging_dir) const override {
    std::error_code ec;
    fs::remove_all(staging_dir, ec);
  }

  void copy_into_staging(const std::string& version_dir, const std::string& staging) const override {
    const auto files = version_files(version_dir);
    const std::string prefix = version_prefix(version_dir);
    for (const S3ListEntry& e : list_all(*client_, where_.bucket, prefix)) {
      const std::string name = e.key.substr(prefix.size());
      if (name == "manifest.json" || name.find('/') != std::string::npos) continue;
      const std::optional<std::string> bytes = files->read(name);
      if (!bytes) throw std::runtime_error(location_ + ": " + version_dir + "/" + name + " vanished while being copied");
      write_local(fs::path(staging) / name, *bytes);
    }
  }

  std::shared_ptr<void> lock_id(const std::string& id) override {
    std::shared_ptr<std::mutex> mu;
    {
      std::lock_guard lock(locks_mu_);
      auto& slot = locks_[id];
      if (!slot) slot = std::make_shared<std::mutex>();
      mu = slot;
    }
    mu->lock();
    return std::shared_ptr<void>(mu.get(), [mu](void*) { mu->unlock(); });
  }

  void commit_version(const std::string& staging_dir, const std::string& id, const std::string& version_dir) override {
    const std::string prefix = version_prefix(version_dir);
    try {
      // Every file the staging folder holds is the version's, in name order (the same order on
      // every try), manifest.json last: a version is read by its manifest.
      std::vector<fs::path> files;
      for (const auto& e : fs::directory_iterator(staging_dir))
        if (!e.is_directory() && e.path().filename() != "manifest.json") files.push_back(e.path());
      std::sort(files.begin(), files.end());
      files.push_back(fs::path(staging_dir) / "manifest.json");
      for (const fs::path& f : files)
        client_->put_file(where_.bucket, prefix + f.filename().string(), f.string(), "application/octet-stream", deadline());
      client_->put(where_.bucket, pointer_key(id), version_dir + "\n", "text/plain", deadline());
    } catch (...) {
      discard_staging(staging_dir);
      throw;
    }
    // The staged files are the version's: they become its mirror rather than being fetched again.
    std::error_code ec;
    fs::rename(staging_dir, cache_ / "versions" / version_dir, ec);
    if (ec) discard_staging(staging_dir);
  }

  bool remove_pointer(const std::string& id) override {
    if (!has_pointer(id)) return false;
    client_->remove(where_.bucket, pointer_key(id), deadline());
    return true;
  }

  int collect_garbage(std::chrono::seconds grace, const std::function<void(const std::string&)>& removed_version) override {
    std::set<std::string> live;
    for (const std::string& id : pointer_ids())
      if (auto v = read_pointer(id)) live.insert(*v);
    const std::int64_t now_ms =
        std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
    int removed = 0;
    for (const std::string& version_dir : list_children(*client_, where_.bucket, where_.prefix + "versions/")) {
      if (live.count(version_dir)) continue;
      const std::optional<std::int64_t> created = created_ms(version_dir);
      if (created && now_ms - *created < std::chrono::duration_cast<std::chrono::milliseconds>(grace).count()) continue;
      for (const S3ListEntry& e : list_all(*client_, where_.bucket, version_prefix(version_dir)))
        client_->remove(where_.bucket, e.key, deadline());
      std::error_code ec;
      fs::remove_all(cache_ / "versions" / version_dir, ec);
      removed_version(version_dir);
      ++removed;
    }
    // Staging folders of this host's processes that are gone.
    const std::string me = host_name() + ".";
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(cache_ / "staging", ec)) {
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

  bool readable() const override {
    try {
      client_->list(where_.bucket, where_.prefix + "images/", "/", "", deadline(), 1);
      return true;
    } catch (const std::exception&) {
      return false;
    }
  }

 private:
  std::string pointer_key(const std::string& id) const { return where_.prefix + "images/" + id; }
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

  const std::shared_ptr<S3Client> client_;
  const S3Location where_;
  const std::string location_;
  const fs::path cache_;
  std::mutex locks_mu_;
  std::map<std::string, std::shared_ptr<std::mutex>> locks_;
};

}  // namespace

std::unique_ptr<StoreBackend> bucket_store(const S3Location& where, std::shared_ptr<S3Client> client,
                                           const std::string& cache_dir) {
  return std::make_unique<BucketStore>(where, std::move(client), cache_dir);
}

}  // namespace zoomwarp::tiles
