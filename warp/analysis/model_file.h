// The binary model files kept with an image version (significance.bin, warp_model.bin, gbvs.bin,
// the methods' <method>.<saliency>.bin): an 8-byte magic, the payload, and a trailer — the byte
// count before it and their CRC-32 — so a truncated or damaged file is found before it is
// parsed. Files are written to a temporary name and renamed into place: a reader never sees a
// partial file, and a hard link to an older version's file is replaced, not written through.
//
// Thread safety: free functions and a reader object per parse; nothing shared.
#pragma once

#include <array>
#include <cstdint>
#include <istream>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "tiles/store.h"

namespace zoomwarp::warp {

// A model file that is missing or cannot be used: truncated, failing its checksum, unparsable,
// or made for another image size. what() names the file, never the folder it is in.
class ModelFileError : public std::runtime_error {
 public:
  ModelFileError(std::string file, const std::string& why);
  const std::string& file() const { return file_; }  // the file's name in the version folder

 private:
  std::string file_;
};

using Magic = std::array<char, 8>;

template <typename T>
void put(std::ostream& out, const T& v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof v);
}

template <typename T>
void put_vector(std::ostream& out, const std::vector<T>& v) {
  put(out, std::int64_t(v.size()));
  out.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(T)));
}

// The bytes of one model file being parsed; every failure is a ModelFileError naming it.
class ModelFileReader {
 public:
  ModelFileReader(const char* file, std::string bytes) : file_(file), in_(std::move(bytes)) {}

  [[noreturn]] void damaged(const std::string& why) const { throw ModelFileError(file_, why); }

  template <typename T>
  T get() {
    T v{};
    in_.read(reinterpret_cast<char*>(&v), sizeof v);
    if (!in_) damaged("truncated");
    return v;
  }

  // A length-prefixed array; the length is checked against the bytes left before allocating.
  template <typename T>
  std::vector<T> get_vector() {
    const auto n = get<std::int64_t>();
    if (n < 0 || std::uint64_t(n) > remaining() / sizeof(T)) damaged("an array runs past the end");
    std::vector<T> v(static_cast<std::size_t>(n));
    in_.read(reinterpret_cast<char*>(v.data()), std::streamsize(v.size() * sizeof(T)));
    if (!in_) damaged("truncated");
    return v;
  }

  std::uint64_t remaining() {
    const auto here = in_.tellg();
    in_.seekg(0, std::ios::end);
    const auto end = in_.tellg();
    in_.seekg(here);
    return here < 0 ? 0 : std::uint64_t(end - here);
  }

  std::istream& stream() { return in_; }

 private:
  const char* file_;
  std::istringstream in_;
};

// The whole file `file` of a version; throws ModelFileError(file, "missing").
std::string read_whole(const tiles::ImageEntry& image, const char* file);
bool exists(const tiles::ImageEntry& image, const char* file);

// `bytes` with the trailer appended (format 2: `bytes` starts with its magic).
std::string with_trailer(std::string bytes);

// A binary model file's bytes without its trailer (format 2, checked) or as they are (format 1,
// which had no trailer), and which format it is. Throws ModelFileError when the magic or the
// trailer is wrong. A file that never had a format 1 passes the same magic twice.
std::pair<std::string, int> checked_payload(const char* file, std::string bytes, const Magic& magic1,
                                            const Magic& magic2);

}  // namespace zoomwarp::warp
