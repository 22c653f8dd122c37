// A file read by byte range: a level file opened where the store keeps it (issue 29). A folder's
// is a file descriptor read with pread; a bucket's is an object read by ranged GETs through the
// store's cache (bucket_store.h). The level readers (libtiff in stored_tiles.cc through
// tiff_on_file.h, OpenImageIO in pyramid_reader.cc through an IOProxy) read bucket objects this
// way, so a tile costs one ranged request, not a download of the whole level.
//
// The bytes never change while a reader holds the file: versions are immutable.
//
// Thread safety: read() and size() may be called from any thread, concurrently.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace zoomwarp::tiles {

struct ByteRange {
  std::uint64_t offset = 0, length = 0;
};

class RandomAccessFile {
 public:
  virtual ~RandomAccessFile() = default;

  virtual std::uint64_t size() const = 0;
  // Copies bytes [offset, offset + n) into `dst`, fewer only at the end of the file; returns how
  // many. Throws std::runtime_error when the store cannot answer (StoreUnavailable, store_errors.h,
  // when it is down or slow), never returns a short count for that.
  virtual std::size_t read(std::uint64_t offset, std::size_t n, char* dst) const = 0;
  // Says that `ranges` are about to be read: a remote file fetches those it does not hold, side
  // by side, and returns once they are held (a read of several stored tiles then waits for one
  // round trip, not one per tile). Returns false when some could not be fetched: failures are
  // left for the reads that follow to report.
  virtual bool prefetch(const std::vector<ByteRange>& ranges) const {
    (void)ranges;
    return true;
  }
  // Where the file is, for messages.
  virtual const std::string& name() const = 0;
};

// The local file at `path`, or null when there is none. Throws std::runtime_error when it exists
// but cannot be opened.
std::shared_ptr<const RandomAccessFile> open_local_file(const std::string& path);

// Copies the whole of `file` to a new local file at `path`, `chunk` bytes per read (large reads of
// a bucket object bypass the store's cache). Throws std::runtime_error, removing `path`, on failure.
void copy_to_local_file(const RandomAccessFile& file, const std::string& path, std::size_t chunk = 8u << 20);

}  // namespace zoomwarp::tiles
