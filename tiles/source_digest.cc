#include "tiles/source_digest.h"

#include "tiles/random_access_file.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <unistd.h>

#include <cerrno>
#include <memory>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace zoomwarp::tiles {

namespace {

struct OpenFile {
  int fd;
  ~OpenFile() { ::close(fd); }
};

std::string hex_digits(const unsigned char* digest, unsigned int size) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string hex;
  for (unsigned int i = 0; i < size; ++i) {
    hex += kDigits[digest[i] >> 4];
    hex += kDigits[digest[i] & 15];
  }
  return hex;
}

// Feeds `read_chunk` (which fills the buffer and returns how many bytes, 0 at the end) through
// SHA-256.
template <class ReadChunk>
std::string streamed_sha256_hex(ReadChunk&& read_chunk) {
  const std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx(EVP_MD_CTX_new(), &EVP_MD_CTX_free);
  if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1) throw std::runtime_error("SHA-256 unavailable");
  std::vector<char> chunk(1 << 20);
  while (const std::size_t n = read_chunk(chunk)) {
    if (EVP_DigestUpdate(ctx.get(), chunk.data(), n) != 1) throw std::runtime_error("SHA-256 failed");
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (EVP_DigestFinal_ex(ctx.get(), digest, &size) != 1) throw std::runtime_error("SHA-256 failed");
  return hex_digits(digest, size);
}

}  // namespace

std::string file_sha256_hex(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::system_error(errno, std::generic_category(), "cannot open");
  const OpenFile file{fd};
  return streamed_sha256_hex([&](std::vector<char>& chunk) -> std::size_t {
    for (;;) {
      const ssize_t n = ::read(file.fd, chunk.data(), chunk.size());
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw std::system_error(errno, std::generic_category(), "cannot read");
      return std::size_t(n);
    }
  });
}

std::string file_sha256_hex(const RandomAccessFile& file) {
  std::uint64_t offset = 0;
  return streamed_sha256_hex([&](std::vector<char>& chunk) {
    const std::size_t n = file.read(offset, chunk.size(), chunk.data());
    offset += n;
    return n;
  });
}

std::string sha256_hex(std::string_view data) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (EVP_Digest(data.data(), data.size(), digest, &size, EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("SHA-256 failed");
  return hex_digits(digest, size);
}

}  // namespace zoomwarp::tiles
