#include "tiles/random_access_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace zoomwarp::tiles {

namespace {

class LocalFile final : public RandomAccessFile {
 public:
  LocalFile(int fd, std::uint64_t size, std::string path) : fd_(fd), size_(size), path_(std::move(path)) {}
  ~LocalFile() override { ::close(fd_); }

  std::uint64_t size() const override { return size_; }

  std::size_t read(std::uint64_t offset, std::size_t n, char* dst) const override {
    std::size_t done = 0;
    while (done < n) {
      const ssize_t got = ::pread(fd_, dst + done, n - done, off_t(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) throw std::runtime_error("cannot read " + path_ + ": " + std::strerror(errno));
      if (got == 0) break;
      done += std::size_t(got);
    }
    return done;
  }

  const std::string& name() const override { return path_; }

 private:
  const int fd_;
  const std::uint64_t size_;
  const std::string path_;
};

}  // namespace

std::shared_ptr<const RandomAccessFile> open_local_file(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0 && errno == ENOENT) return nullptr;
  if (fd < 0) throw std::runtime_error("cannot open " + path + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw std::runtime_error("cannot open " + path + ": not a regular file");
  }
  return std::make_shared<LocalFile>(fd, std::uint64_t(st.st_size), path);
}

void copy_to_local_file(const RandomAccessFile& file, const std::string& path, std::size_t chunk) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot create " + path + ": " + std::strerror(errno));
  try {
    std::vector<char> buffer(std::max<std::size_t>(1, chunk));
    for (std::uint64_t offset = 0; offset < file.size();) {
      const std::size_t want = std::size_t(std::min<std::uint64_t>(buffer.size(), file.size() - offset));
      const std::size_t got = file.read(offset, want, buffer.data());
      if (got != want) throw std::runtime_error(file.name() + " ended early");
      for (std::size_t written = 0; written < got;) {
        const ssize_t w = ::write(fd, buffer.data() + written, got - written);
        if (w < 0 && errno == EINTR) continue;
        if (w < 0) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
        written += std::size_t(w);
      }
      offset += got;
    }
    if (::close(fd) != 0) {
      ::unlink(path.c_str());
      throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
    }
  } catch (...) {
    ::close(fd);
    ::unlink(path.c_str());
    throw;
  }
}

}  // namespace zoomwarp::tiles
