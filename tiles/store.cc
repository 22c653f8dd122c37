#include "tiles/store.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "tiles/image_id.h"
#include "tiles/pyramid_builder.h"

namespace zoomwarp::tiles {

namespace fs = std::filesystem;

namespace {

std::uint64_t random_u64() {
  static thread_local std::mt19937_64 rng{std::random_device{}() ^
                                          std::uint64_t(::getpid()) << 32 ^
                                          std::uint64_t(std::chrono::steady_clock::now()
                                                            .time_since_epoch()
                                                            .count())};
  return rng();
}

std::string hex(std::uint64_t v, int digits) {
  static const char* d = "0123456789abcdef";
  std::string s(digits, '0');
  for (int i = digits - 1; i >= 0; --i, v >>= 4) s[i] = d[v & 15];
  return s;
}

std::string host_name() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "host";
  std::string h(buf);
  std::replace(h.begin(), h.end(), '.', '_');
  return h;
}

std::int64_t now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + p.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Writes a file and makes it durable before the folder holding it is published.
void write_file_synced(const fs::path& p, const std::string& text) {
  std::FILE* f = std::fopen(p.c_str(), "wb");
  if (!f) throw std::runtime_error("cannot write " + p.string());
  bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size() && std::fflush(f) == 0 &&
            ::fsync(::fileno(f)) == 0;
  ok = std::fclose(f) == 0 && ok;
  if (!ok) throw std::runtime_error("cannot write " + p.string());
}

bool old_enough(const fs::path& p, std::chrono::seconds age) {
  std::error_code ec;
  auto t = fs::last_write_time(p, ec);
  if (ec) return false;
  return fs::file_time_type::clock::now() - t > age;
}

}  // namespace

std::string ImageEntry::level_path(int k) const { return dir + "/" + level_filename(k); }

Store::Store(const std::string& root, std::chrono::milliseconds recheck) : recheck_(recheck) {
  std::error_code ec;
  fs::create_directories(fs::path(root) / "images", ec);
  fs::create_directories(fs::path(root) / "versions", ec);
  fs::create_directories(fs::path(root) / "staging", ec);
  fs::create_directories(fs::path(root) / "locks", ec);
  if (ec || !fs::is_directory(fs::path(root) / "images"))
    throw std::runtime_error("cannot create the store at " + root + ": " + ec.message());
  root_ = fs::canonical(root).string();
}

std::shared_ptr<const ImageEntry> Store::load_version(const std::string& id,
                                                      const std::string& version_dir) const {
  {
    std::lock_guard lock(mu_);
    if (auto it = versions_.find(version_dir); it != versions_.end()) return it->second;
  }
  auto entry = std::make_shared<ImageEntry>();
  entry->dir = root_ + "/versions/" + version_dir;
  try {
    entry->manifest = manifest_from_json(read_file(entry->dir + "/manifest.json"));
  } catch (const std::exception&) {
    return nullptr;  // a link to a missing or damaged version is not a published image
  }
  if (entry->manifest.id != id || version_dir != id + "@" + entry->manifest.version) return nullptr;
  std::lock_guard lock(mu_);
  return versions_.emplace(version_dir, std::move(entry)).first->second;
}

std::shared_ptr<const ImageEntry> Store::find(const std::string& id) const {
  if (!is_valid_image_id(id)) return nullptr;
  const auto now = std::chrono::steady_clock::now();
  std::uint64_t generation;
  {
    std::shared_lock lock(links_mu_);
    if (auto it = links_.find(id); it != links_.end() && now - it->second.read_at < recheck_)
      return it->second.entry;
    generation = generation_;
  }
  auto entry = read_link(id);
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
  char target[512];
  const std::string link = root_ + "/images/" + id;
  ssize_t n = ::readlink(link.c_str(), target, sizeof target - 1);
  if (n <= 0) return nullptr;
  std::string_view t(target, std::size_t(n));
  constexpr std::string_view prefix = "../versions/";
  if (!t.starts_with(prefix)) return nullptr;
  t.remove_prefix(prefix.size());
  if (t.find('/') != std::string_view::npos) return nullptr;
  return load_version(id, std::string(t));
}

bool Store::published(const std::string& id) const {
  if (!is_valid_image_id(id)) return false;
  struct stat st;
  return ::lstat((root_ + "/images/" + id).c_str(), &st) == 0;
}

std::vector<std::shared_ptr<const ImageEntry>> Store::list() const {
  std::vector<std::shared_ptr<const ImageEntry>> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root_ + "/images", ec)) {
    const std::string name = e.path().filename().string();
    if (auto entry = find(name)) out.push_back(std::move(entry));
  }
  std::sort(out.begin(), out.end(),
            [](const auto& a, const auto& b) { return a->manifest.id < b->manifest.id; });
  return out;
}

std::string Store::make_staging_dir() const {
  for (int attempt = 0; attempt < 8; ++attempt) {
    fs::path p = fs::path(root_) / "staging" /
                 (host_name() + "." + std::to_string(::getpid()) + "." + hex(random_u64(), 12));
    std::error_code ec;
    if (fs::create_directory(p, ec)) return p.string();
  }
  throw std::runtime_error("cannot create a staging folder in " + root_);
}

void Store::discard(const std::string& staging_dir) const {
  std::error_code ec;
  fs::remove_all(staging_dir, ec);
}

std::string Store::make_staging_copy(const ImageEntry& from) const {
  const std::string staging = make_staging_dir();
  try {
    for (const auto& e : fs::directory_iterator(from.dir)) {
      if (e.path().filename() == "manifest.json") continue;
      std::error_code ec;
      fs::create_hard_link(e.path(), fs::path(staging) / e.path().filename(), ec);
      if (ec) fs::copy_file(e.path(), fs::path(staging) / e.path().filename());  // another file system
    }
  } catch (...) {
    discard(staging);
    throw;
  }
  return staging;
}

namespace {

// An exclusive flock() on ROOT/locks/ID for the life of the object.
class IdLock {
 public:
  IdLock(const std::string& root, const std::string& id)
      : fd_(::open((root + "/locks/" + id).c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644)) {
    if (fd_ >= 0 && ::flock(fd_, LOCK_EX) == 0) return;
    if (fd_ >= 0) ::close(fd_);
    throw std::runtime_error("cannot lock image " + id);
  }
  ~IdLock() { ::close(fd_); }
  IdLock(const IdLock&) = delete;
  IdLock& operator=(const IdLock&) = delete;

 private:
  int fd_;
};

}  // namespace

std::shared_ptr<const ImageEntry> Store::publish(const std::string& staging_dir, Manifest m,
                                                 const std::string* expected_version) {
  if (!is_valid_image_id(m.id)) throw std::runtime_error("invalid image id");
  // Every publish and remove of an id holds its lock, so a conditional publish's check and swap
  // are one step for all of them.
  const IdLock lock(root_, m.id);
  if (expected_version) {
    const auto current = read_link(m.id);  // not a remembered reading: another process may have published
    if (!current || current->manifest.version != *expected_version) {
      discard(staging_dir);
      throw VersionConflict("image " + m.id + " changed since version " + *expected_version);
    }
  }
  m.created_ms = now_ms();
  // The version orders publishes in time and is unique across processes and hosts.
  m.version = hex(std::uint64_t(m.created_ms), 11) + hex(random_u64(), 5);
  write_file_synced(fs::path(staging_dir) / "manifest.json", manifest_to_json(m));

  const std::string version_dir = m.id + "@" + m.version;
  fs::rename(staging_dir, fs::path(root_) / "versions" / version_dir);
  // Replace the link atomically: make it under a temporary name, then rename it over the old one.
  const fs::path link = fs::path(root_) / "images" / m.id;
  const fs::path tmp_link =
      fs::path(root_) / "staging" /
      (host_name() + "." + std::to_string(::getpid()) + "." + hex(random_u64(), 12) + ".link");
  fs::create_symlink("../versions/" + version_dir, tmp_link);
  fs::rename(tmp_link, link);
  forget_link(m.id);
  auto entry = find(m.id);
  if (!entry) throw std::runtime_error("published image " + m.id + " cannot be read back");
  return entry;
}

bool Store::remove(const std::string& id) {
  if (!is_valid_image_id(id)) return false;
  const IdLock lock(root_, id);
  const bool removed = ::unlink((root_ + "/images/" + id).c_str()) == 0;
  forget_link(id);
  return removed;
}

int Store::collect_garbage(std::chrono::seconds grace) {
  std::vector<std::string> live;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root_ + "/images", ec)) {
    char target[512];
    ssize_t n = ::readlink(e.path().c_str(), target, sizeof target - 1);
    if (n > 0) live.push_back(fs::path(std::string(target, std::size_t(n))).filename().string());
  }
  int removed = 0;
  for (const auto& e : fs::directory_iterator(root_ + "/versions", ec)) {
    const std::string name = e.path().filename().string();
    if (std::find(live.begin(), live.end(), name) != live.end()) continue;
    if (!old_enough(e.path(), grace)) continue;
    std::error_code rec;
    fs::remove_all(e.path(), rec);
    if (!rec) {
      ++removed;
      std::lock_guard lock(mu_);
      versions_.erase(name);
    }
  }
  const std::string me = host_name() + ".";
  for (const auto& e : fs::directory_iterator(root_ + "/staging", ec)) {
    const std::string name = e.path().filename().string();
    bool dead = false;
    if (name.starts_with(me)) {  // HOST.PID.RANDOM of this host: is PID still running?
      const std::string pid = name.substr(me.size(), name.find('.', me.size()) - me.size());
      dead = !pid.empty() && pid != std::to_string(::getpid()) &&
             !fs::exists("/proc/" + pid);
    }
    if (dead || old_enough(e.path(), std::chrono::hours(24))) {
      std::error_code rec;
      fs::remove_all(e.path(), rec);
      if (!rec) ++removed;
    }
  }
  return removed;
}

bool Store::readable() const {
  return ::access((root_ + "/images").c_str(), R_OK | X_OK) == 0 &&
         ::access((root_ + "/versions").c_str(), R_OK | X_OK) == 0;
}

}  // namespace zoomwarp::tiles
