// libtiff reading a RandomAccessFile (TIFFClientOpen): a level file in a bucket, read by byte
// range (issue 29). libtiff is C: a read that throws (a store that is down or slow) must not
// unwind through it, so the failure is kept and the caller rethrows it once libtiff has returned
// its error (a 503 stays a 503, not "cannot read").
//
// Thread safety: like a TIFF*, one thread at a time.
#pragma once

#include <tiffio.h>

#include <exception>
#include <memory>
#include <string>

#include "tiles/random_access_file.h"

namespace zoomwarp::tiles {

class TiffOnFile {
 public:
  // Opens `file` for reading with `options` (error handlers), or throws std::runtime_error (the
  // read's own exception, if one failed) when libtiff cannot.
  TiffOnFile(std::shared_ptr<const RandomAccessFile> file, TIFFOpenOptions* options);
  ~TiffOnFile();
  TiffOnFile(const TiffOnFile&) = delete;
  TiffOnFile& operator=(const TiffOnFile&) = delete;

  TIFF* tif() const { return tif_; }
  // After a libtiff call failed: rethrows what a read threw during it, if anything (and forgets
  // it, so the next call starts clean).
  void rethrow_read_failure();

  struct State {
    std::shared_ptr<const RandomAccessFile> file;
    std::uint64_t position = 0;
    std::exception_ptr failure;
  };

 private:
  State state_;
  TIFF* tif_ = nullptr;
};

}  // namespace zoomwarp::tiles
