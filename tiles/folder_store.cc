#include "tiles/folder_store.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <stdexcept>

#include "tiles/image_id.h"
#include "tiles/unique_names.h"

namespace zoomwarp::tiles {

namespace fs = std::filesystem;

namespace {

bool old_enough(const fs::path& p, std::chrono::seconds age) {
  std::error_code ec;
  auto t = fs::last_write_time(p, ec);
  if (ec) return false;
  return fs::file_time_type::clock::now() - t > age;
}

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

class FolderStore final : public StoreBackend {
 public:
  explicit FolderStore(const std::string& root) {
    std::error_code ec;
    for (const char* sub : {"images", "versions", "staging", "locks"}) fs::create_directories(fs::path(root) / sub, ec);
    if (ec || !fs::is_directory(fs::path(root) / "images"))
      throw std::runtime_error("cannot create the store at " + root + ": " + ec.message());
    root_ = fs::canonical(root).string();
  }

  const std::string& location() const override { return root_; }

  std::optional<std::string> read_pointer(const std::string& id) const override {
    char target[512];
    const std::string link = root_ + "/images/" + id;
    const ssize_t n = ::readlink(link.c_str(), target, sizeof target - 1);
    if (n <= 0) return std::nullopt;
    std::string_view t(target, std::size_t(n));
    constexpr std::string_view prefix = "../versions/";
    if (!t.starts_with(prefix)) return std::nullopt;
    t.remove_prefix(prefix.size());
    if (t.find('/') != std::string_view::npos) return std::nullopt;
    return std::string(t);
  }

  bool has_pointer(const std::string& id) const override {
    struct stat st;
    return ::lstat((root_ + "/images/" + id).c_str(), &st) == 0;
  }

  std::vector<std::string> pointer_ids() const override {
    std::vector<std::string> out;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(root_ + "/images", ec)) out.push_back(e.path().filename().string());
    return out;
  }

  std::shared_ptr<const VersionFiles> version_files(const std::string& version_dir) const override {
    return folder_files(root_ + "/versions/" + version_dir);
  }

  std::string make_staging_dir() const override {
    for (int attempt = 0; attempt < 8; ++attempt) {
      const fs::path p = fs::path(root_) / "staging" / owned_unique_name();
      std::error_code ec;
      if (fs::create_directory(p, ec)) return p.string();
    }
    throw std::runtime_error("cannot create a staging folder in " + root_);
  }

  void discard_staging(const std::string& staging_dir) const override {
    std::error_code ec;
    fs::remove_all(staging_dir, ec);
  }

  void copy_into_staging(const std::string& version_dir, const std::string& staging) const override {
    // Hard links: the edit writes new files under temporary names renamed over them, so the
    // published version's files are never written through.
    for (const auto& e : fs::directory_iterator(root_ + "/versions/" + version_dir)) {
      if (e.path().filename() == "manifest.json") continue;
      std::error_code ec;
      fs::create_hard_link(e.path(), fs::path(staging) / e.path().filename(), ec);
      if (ec) fs::copy_file(e.path(), fs::path(staging) / e.path().filename());  // another file system
    }
  }

  std::shared_ptr<void> lock_id(const std::string& id) override { return std::make_shared<IdLock>(root_, id); }

  void commit_version(const std::string& staging_dir, const std::string& id, const std::string& version_dir) override {
    try {
      fs::rename(staging_dir, fs::path(root_) / "versions" / version_dir);
    } catch (...) {
      discard_staging(staging_dir);
      throw;
    }
    // Replace the link atomically: make it under a temporary name, then rename it over the old one.
    const fs::path tmp_link = fs::path(root_) / "staging" / (owned_unique_name() + ".link");
    fs::create_symlink("../versions/" + version_dir, tmp_link);
    fs::rename(tmp_link, fs::path(root_) / "images" / id);
  }

  bool remove_pointer(const std::string& id) override { return ::unlink((root_ + "/images/" + id).c_str()) == 0; }

  int collect_garbage(std::chrono::seconds grace, const std::function<void(const std::string&)>& removed_version) override {
    std::vector<std::string> live;
    for (const std::string& id : pointer_ids())
      if (auto v = read_pointer(id)) live.push_back(*v);
    int removed = 0;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(root_ + "/versions", ec)) {
      const std::string name = e.path().filename().string();
      if (std::find(live.begin(), live.end(), name) != live.end()) continue;
      if (!old_enough(e.path(), grace)) continue;
      std::error_code rec;
      fs::remove_all(e.path(), rec);
      if (!rec) {
        ++removed;
        removed_version(name);
      }
    }
    const std::string me = host_name() + ".";
    for (const auto& e : fs::directory_iterator(root_ + "/staging", ec)) {
      const std::string name = e.path().filename().string();
      bool dead = false;
      if (name.starts_with(me)) {  // HOST.PID.RANDOM of this host: is PID still running?
        const std::string pid = name.substr(me.size(), name.find('.', me.size()) - me.size());
        dead = !pid.empty() && pid != std::to_string(::getpid()) && !fs::exists("/proc/" + pid);
      }
      if (dead || old_enough(e.path(), std::chrono::hours(24))) {
        std::error_code rec;
        fs::remove_all(e.path(), rec);
        if (!rec) ++removed;
      }
    }
    return removed;
  }

  std::string problem(std::chrono::milliseconds) const override {
    for (const char* sub : {"/images", "/versions"})
      if (::access((root_ + sub).c_str(), R_OK | X_OK) != 0) return root_ + sub + " is not readable";
    return "";
  }

 private:
  std::string root_;
};

}  // namespace

std::unique_ptr<StoreBackend> folder_store(const std::string& root) { return std::make_unique<FolderStore>(root); }

}  // namespace zoomwarp::tiles
