#include "tiles/folder_store.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "tiles/image_id.h"
#include "tiles/superseded_versions.h"
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
    for (const char* sub : {"images", "versions", "staging", "locks", kSupersededFolder})
      fs::create_directories(fs::path(root) / sub, ec);
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

  void store_version(const std::string& staging_dir, const std::string& version_dir) override {
    try {
      fs::rename(staging_dir, fs::path(root_) / "versions" / version_dir);
    } catch (...) {
      discard_staging(staging_dir);
      throw;
    }
  }

  void point(const std::string& id, const std::string& version_dir) override {
    mark_unpublished(id, version_dir);
    // Replace the link atomically: make it under a temporary name, then rename it over the old one.
    const fs::path tmp_link = fs::path(root_) / "staging" / (owned_unique_name() + ".link");
    fs::create_symlink("../versions/" + version_dir, tmp_link);
    fs::rename(tmp_link, fs::path(root_) / "images" / id);
  }

  bool remove_pointer(const std::string& id) override {
    mark_unpublished(id, "");
    return ::unlink((root_ + "/images/" + id).c_str()) == 0;
  }

  int collect_garbage(std::chrono::seconds grace, const std::function<void(const std::string&)>& removed_version) override {
    std::vector<std::string> live;
    for (const std::string& id : pointer_ids())
      if (auto v = read_pointer(id)) live.push_back(*v);
    int removed = 0;
    std::error_code ec;
    // By supersede time (superseded_versions.h): a version unnamed for the grace goes.
    const std::int64_t now_ms = unix_ms_now();
    for (const auto& e : fs::directory_iterator(root_ + "/versions", ec)) {
      const std::string name = e.path().filename().string();
      const bool named = std::find(live.begin(), live.end(), name) != live.end();
      switch (collect_verdict(named, named ? std::nullopt : read_mark(name), modified_ms(e.path()), now_ms, grace)) {
        case Collect::kKeep:
          break;
        case Collect::kMark:
          write_mark(name, now_ms);
          break;
        case Collect::kRemove: {
          std::error_code rec;
          fs::remove_all(e.path(), rec);
          if (!rec) {
            fs::remove(mark_path(name), rec);
            ++removed;
            removed_version(name);
          }
          break;
        }
      }
    }
    // Marks of versions named again (a mark written before a pointer move that then failed) or gone.
    for (const auto& e : fs::directory_iterator(root_ + "/" + kSupersededFolder, ec)) {
      const std::string name = e.path().filename().string();
      if (std::find(live.begin(), live.end(), name) != live.end() || !fs::exists(root_ + "/versions/" + name)) {
        std::error_code rec;
        fs::remove(e.path(), rec);
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
  std::string mark_path(const std::string& version_dir) const { return root_ + "/" + kSupersededFolder + "/" + version_dir; }
  std::optional<std::int64_t> read_mark(const std::string& version_dir) const {
    std::error_code ec;
    if (!fs::exists(mark_path(version_dir), ec)) return std::nullopt;
    std::ifstream in(mark_path(version_dir));
    const std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return parse_superseded_mark(body);
  }
  // Written whole under a temporary name, then renamed: a reader never sees half a mark.
  void write_mark(const std::string& version_dir, std::int64_t unix_ms) const {
    const fs::path tmp = fs::path(root_) / "staging" / (owned_unique_name() + ".superseded");
    {
      std::ofstream out(tmp);
      out << superseded_mark(unix_ms);
      if (!out.flush()) throw std::runtime_error("cannot write " + tmp.string());
    }
    fs::rename(tmp, mark_path(version_dir));
  }
  // Before images/ID moves to `next` (or away, for ""): the version it names now is superseded now.
  void mark_unpublished(const std::string& id, const std::string& next) const {
    if (const std::optional<std::string> now = read_pointer(id); now && *now != next) write_mark(*now, unix_ms_now());
  }
  static std::optional<std::int64_t> modified_ms(const fs::path& p) {
    std::error_code ec;
    const auto t = fs::last_write_time(p, ec);
    if (ec) return std::nullopt;
    const auto since = t - fs::file_time_type::clock::now();
    return unix_ms_now() + std::chrono::duration_cast<std::chrono::milliseconds>(since).count();
  }

  std::string root_;
};

}  // namespace

std::unique_ptr<StoreBackend> folder_store(const std::string& root) { return std::make_unique<FolderStore>(root); }

}  // namespace zoomwarp::tiles
