#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "tiles/version_files.h"

namespace zoomwarp::tiles {

namespace fs = std::filesystem;

namespace {

class FolderFiles final : public VersionFiles {
 public:
  explicit FolderFiles(std::string dir) : dir_(std::move(dir)) {}

  std::optional<std::string> read(const std::string& name) const override {
    std::ifstream in(fs::path(dir_) / name, std::ios::binary);
    if (!in) return std::nullopt;
    std::ostringstream s;
    s << in.rdbuf();
    if (in.bad()) throw std::runtime_error("cannot read " + dir_ + "/" + name);
    return s.str();
  }

  bool exists(const std::string& name) const override {
    std::error_code ec;
    return fs::exists(fs::path(dir_) / name, ec);
  }

  void write(const std::string& name, const std::string& bytes) const override {
    // A temporary name of this writer's own: replicas and threads computing the same analysis for
    // a published version write the same file at once, and must not share one temporary.
    static std::atomic<std::uint64_t> writes{0};
    const fs::path path = fs::path(dir_) / name,
                   tmp = fs::path(dir_) / (name + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(++writes));
    {
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      out.write(bytes.data(), std::streamsize(bytes.size()));
      if (!out.flush()) {
        out.close();
        std::error_code ec;
        fs::remove(tmp, ec);
        throw std::runtime_error("cannot write " + tmp.string());
      }
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) {
      fs::remove(tmp, ec);
      throw std::runtime_error("cannot rename " + tmp.string() + " into place");
    }
  }

  std::vector<std::string> names() const override {
    std::vector<std::string> out;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_, ec)) {
      const std::string name = e.path().filename().string();
      if (name.find(".tmp.") == std::string::npos && !e.is_directory()) out.push_back(name);
    }
    if (ec) throw std::runtime_error("cannot list " + dir_ + ": " + ec.message());
    return out;
  }

  std::shared_ptr<const RandomAccessFile> open(const std::string& name) const override {
    return open_local_file(dir_ + "/" + name);
  }

  std::optional<std::string> local_path(const std::string& name) const override { return dir_ + "/" + name; }

  const std::string& location() const override { return dir_; }

 private:
  const std::string dir_;
};

}  // namespace

std::shared_ptr<const VersionFiles> folder_files(std::string dir) { return std::make_shared<FolderFiles>(std::move(dir)); }

}  // namespace zoomwarp::tiles
