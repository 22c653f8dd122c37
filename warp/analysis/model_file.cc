#include "warp/analysis/model_file.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/crc.hpp>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace zoomwarp::warp {

namespace {

namespace fs = std::filesystem;

// Format 2's trailer: the number of bytes before it and their CRC-32.
struct Trailer {
  std::uint64_t length;
  std::uint32_t crc;
};
constexpr std::size_t kTrailerBytes = sizeof(std::uint64_t) + sizeof(std::uint32_t);

std::uint32_t crc32_of(std::string_view bytes) {
  boost::crc_32_type crc;
  crc.process_bytes(bytes.data(), bytes.size());
  return crc.checksum();
}

}  // namespace

ModelFileError::ModelFileError(std::string file, const std::string& why)
    : std::runtime_error(file + ": " + why), file_(std::move(file)) {}

std::string read_whole(const tiles::ImageEntry& image, const char* file) {
  std::optional<std::string> bytes = image.files->read(file);
  if (!bytes) throw ModelFileError(file, "missing");
  return std::move(*bytes);
}

bool exists(const tiles::ImageEntry& image, const char* file) { return image.files->exists(file); }

// Appends the format 2 trailer.
std::string with_trailer(std::string bytes) {
  const std::uint64_t length = bytes.size();
  const std::uint32_t crc = crc32_of(bytes);
  bytes.append(reinterpret_cast<const char*>(&length), sizeof length);
  bytes.append(reinterpret_cast<const char*>(&crc), sizeof crc);
  return bytes;
}

// A binary model file's bytes without its trailer (format 2, checked) or as they are (format 1),
// and which format it is. Throws ModelFileError when the magic or the trailer is wrong.
std::pair<std::string, int> checked_payload(const char* file, std::string bytes, const Magic& magic1,
                                            const Magic& magic2) {
  if (bytes.size() < magic1.size()) throw ModelFileError(file, "truncated");
  if (!std::equal(magic2.begin(), magic2.end(), bytes.begin())) {
    if (std::equal(magic1.begin(), magic1.end(), bytes.begin())) return {std::move(bytes), 1};
    throw ModelFileError(file, "not a model file");
  }
  if (bytes.size() < magic2.size() + kTrailerBytes) throw ModelFileError(file, "truncated");
  Trailer t;
  const std::size_t body = bytes.size() - kTrailerBytes;
  std::memcpy(&t.length, bytes.data() + body, sizeof t.length);
  std::memcpy(&t.crc, bytes.data() + body + sizeof t.length, sizeof t.crc);
  if (t.length != body) throw ModelFileError(file, "truncated or extended");
  bytes.resize(body);
  if (crc32_of(bytes) != t.crc) throw ModelFileError(file, "checksum mismatch");
  return {std::move(bytes), 2};
}

}  // namespace zoomwarp::warp
