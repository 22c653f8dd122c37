#include "tiles/store.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "tiles/bucket_store.h"
#include "tiles/store_errors.h"
#include "tiles/folder_store.h"
#include "tiles/image_id.h"
#include "tiles/pyramid_builder.h"
#include "tiles/unique_names.h"

namespace zoomwarp::tiles {

namespace {

std::int64_t now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Writes a file and makes it durable before the version holding it is committed.
void write_file_synced(const std::string& path, const std::string& text) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw std::runtime_error("cannot write " + path);
  bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size() && std::fflush(f) == 0 &&
            ::fsync(::fileno(f)) == 0;
  ok = std::fclose(f) == 0 && ok;
  if (!ok) throw std::runtime_error("cannot write " + path);
}

}  // namespace

std::string ImageEntry::level_path(int k) const {
  const auto path = files->local_path(level_filename(k));
  if (!path) throw std::runtime_error(files->location() + ": level " + std::to_string(k) + " is not a local file");
  return *path;
}

namespace {

// s3://BUCKET/PREFIX: credentials and endpoint from the AWS environment (s3_config.h). Refused
// credentials stop the start with S3's own message; a store that is down does not (readiness says
// so, and service begins when it answers).
std::unique_ptr<StoreBackend> open_backend(const std::string& location, const BucketStoreOptions& cache) {
  if (!location.starts_with("s3://")) return folder_store(location);
  const S3Location where = parse_s3_location(location);
  auto client = std::make_shared<S3Client>(S3Config::from_environment());
  try {
    client->list(where.bucket, where.prefix + "images/", "/", "", std::chrono::steady_clock::now() + std::chrono::seconds(10), 1);
  } catch (const S3Error& e) {
    if (e.credentials_refused() || e.code() == "NoSuchBucket") throw std::runtime_error(location + ": " + e.what());
  }
  RangeCacheOptions ranges;
  ranges.memory_bytes = cache.memory_bytes;
  std::string local = cache.dir;
  if (local.empty()) {
    const char* tmp = std::getenv("TMPDIR");
    local = std::string(tmp && *tmp ? tmp : "/tmp") + "/zoomwarp-store-cache/" + where.bucket + "/" + where.prefix;
  } else if (cache.disk_bytes > 0) {
    ranges.disk_dir = cache.dir;
    ranges.disk_bytes = cache.disk_bytes;
  }
  return bucket_store(where, std::move(client), local, ranges, cache.lease);
}

}  // namespace

Store::Store(const std::string& location, std::chrono::milliseconds recheck, const BucketStoreOptions& cache)
    : backend_(open_backend(location, cache)), recheck_(recheck) {}

Store::~Store() = default;

const std::string& Store::root() const { return backend_->location(); }

std::shared_ptr<const ImageEntry> Store::load_version(const std::string& id, const std::string& version_dir) const {
  {
    std::lock_guard lock(mu_);
    if (auto it = versions_.find(version_dir); it != versions_.end()) return it->second;
  }
  auto entry = std::make_shared<ImageEntry>();
  entry->files = backend_->version_files(version_dir);
  try {
    const std::optional<std::string> manifest = entry->files->read("manifest.json");
    if (!manifest) return nullptr;
    entry->manifest = manifest_from_json(*manifest);
  } catch (const std::exception&) {
    return nullptr;  // a pointer to a missing or damaged version is not a published image
  }
  if (entry->manifest.id != id || version_dir != id + "@" + entry->manifest.version) return nullptr;
  std::lock_guard lock(mu_);
  return versions_.emplace(version_dir, std::move(entry)).first->second;
}

std::shared_ptr<const ImageEntry> Store::find(const std::string& id) const {
  if (!is_valid_image_id(id)) return nullptr;
  const auto now = std::chrono::steady_clock::now();
  std::uint64_t generation;
  std::shared_ptr<const ImageEntry> remembered;
  {
    std::shared_lock lock(links_mu_);
    if (auto it = links_.find(id); it != links_.end()) {
      if (now - it->second.read_at < recheck_) return it->second.entry;
      remembered = it->second.entry;
    }
    generation = generation_;
  }
  std::shared_ptr<const ImageEntry> entry;
  try {
    entry = read_link(id);
  } catch (const StoreUnavailable& e) {
    // Stale while the store is known to be down: what was published then is served from what is
    // held here (its files are immutable), trusted for another interval. Not when the store was
    // not asked for want of time (the I/O thread): a worker asks it.
    if (!remembered || !e.known_down()) throw;
    entry = remembered;
  }
  std::unique_lock lock(links_mu_);
  if (generation == generation_) {
    if (entry) links_.insert_or_assign(id, LinkReading{entry, now});
    else links_.erase(id);
  }
  return entry;
}

void Store::forget_link(const std::string& id) {
  std::unique_lock lock(links_mu_);
  ++generation_;
  links_.erase(id);
}

std::shared_ptr<const ImageEntry> Store::read_link(const std::string& id) const {
  const std::optional<std::string> version_dir = backend_->read_pointer(id);
  return version_dir ? load_version(id, *version_dir) : nullptr;
}

bool Store::published(const std::string& id) const { return is_valid_image_id(id) && backend_->has_pointer(id); }

std::size_t Store::count() const { return backend_->pointer_ids().size(); }

std::vector<std::shared_ptr<const ImageEntry>> Store::list() const {
  std::vector<std::shared_ptr<const ImageEntry>> out;
  for (const std::string& id : backend_->pointer_ids())
    if (auto entry = find(id)) out.push_back(std::move(entry));
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a->manifest.id < b->manifest.id; });
  return out;
}

std::string Store::make_staging_dir() const { return backend_->make_staging_dir(); }

void Store::discard(const std::string& staging_dir) const { backend_->discard_staging(staging_dir); }

std::string Store::make_staging_copy(const ImageEntry& from) const {
  const std::string staging = backend_->make_staging_dir();
  try {
    backend_->copy_into_staging(from.manifest.id + "@" + from.manifest.version, staging);
  } catch (...) {
    backend_->discard_staging(staging);
    throw;
  }
  return staging;
}

std::shared_ptr<const ImageEntry> Store::find_now(const std::string& id) const {
  if (!is_valid_image_id(id)) return nullptr;
  return read_link(id);
}

namespace {
bool is_expected(const std::shared_ptr<const ImageEntry>& current, const std::string& expected) {
  return current ? current->manifest.version == expected : expected.empty();
}
std::string conflict_message(const std::string& id, const std::string& expected) {
  return expected.empty() ? "image " + id + " was published meanwhile"
                          : "image " + id + " changed since version " + expected;
}
}  // namespace

std::shared_ptr<const ImageEntry> Store::publish(const std::string& staging_dir, Manifest m,
                                                 const std::string* expected_version) {
  if (!is_valid_image_id(m.id)) {
    discard(staging_dir);
    throw std::runtime_error("invalid image id");
  }
  // Not a remembered reading: another process may have published. Checked before the upload, so
  // that a stale edit costs no version.
  if (expected_version && !is_expected(read_link(m.id), *expected_version)) {
    discard(staging_dir);
    throw VersionConflict(conflict_message(m.id, *expected_version));
  }
  m.created_ms = now_ms();
  // The version orders publishes in time and is unique across processes and hosts.
  m.version = hex(std::uint64_t(m.created_ms), 11) + hex(random_u64(), 5);
  const std::string version_dir = m.id + "@" + m.version;
  try {
    write_file_synced(staging_dir + "/manifest.json", manifest_to_json(m));
  } catch (...) {
    discard(staging_dir);
    throw;
  }
  backend_->store_version(staging_dir, version_dir);
  {
    // Every publish and remove of an id holds its lock, so a conditional publish's check and
    // move are one step for all of them, in every process.
    const auto lock = backend_->lock_id(m.id);
    if (expected_version && !is_expected(read_link(m.id), *expected_version))
      throw VersionConflict(conflict_message(m.id, *expected_version),
                            load_version(m.id, version_dir));
    backend_->point(m.id, version_dir);
  }
  forget_link(m.id);
  auto entry = find(m.id);
  if (!entry) throw std::runtime_error("published image " + m.id + " cannot be read back");
  return entry;
}

std::shared_ptr<const ImageEntry> Store::import(const std::string& staging_dir, const Manifest& m) {
  if (!is_valid_image_id(m.id) || m.version.empty()) throw std::runtime_error("invalid image id or version");
  const std::string version_dir = m.id + "@" + m.version;
  if (backend_->version_files(version_dir)->exists("manifest.json")) {
    discard(staging_dir);
    throw std::runtime_error(root() + " holds " + version_dir + " already");
  }
  try {
    write_file_synced(staging_dir + "/manifest.json", manifest_to_json(m));
  } catch (...) {
    discard(staging_dir);
    throw;
  }
  backend_->store_version(staging_dir, version_dir);
  {
    const auto lock = backend_->lock_id(m.id);
    backend_->point(m.id, version_dir);
  }
  forget_link(m.id);
  auto entry = find(m.id);
  if (!entry || entry->manifest.version != m.version)
    throw std::runtime_error("imported image " + version_dir + " cannot be read back");
  return entry;
}

bool Store::remove(const std::string& id) {
  if (!is_valid_image_id(id)) return false;
  const auto lock = backend_->lock_id(id);
  const bool removed = backend_->remove_pointer(id);
  forget_link(id);
  return removed;
}

int Store::collect_garbage(std::chrono::seconds grace) {
  return backend_->collect_garbage(grace, [this](const std::string& version_dir) {
    std::lock_guard lock(mu_);
    versions_.erase(version_dir);
  });
}

std::uint64_t Store::generation() const {
  std::shared_lock lock(links_mu_);
  return generation_;
}

std::string Store::problem(std::chrono::milliseconds within) const { return backend_->problem(within); }

StoreStats Store::stats() const { return backend_->stats(); }

}  // namespace zoomwarp::tiles
