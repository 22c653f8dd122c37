// Why an ingest failed, as its callers answer it: an upload's 415/413/422/500, `zoomwarp
// ingest`'s exit codes. Thrown by the pyramid's reading (pyramid_builder.h) and writing
// (level_file.h) and by the ingest as a whole (ingest.h).
#pragma once

#include <stdexcept>
#include <string>

namespace zoomwarp::tiles {

class IngestError : public std::runtime_error {
 public:
  enum class Kind {
    kUnsupportedFormat,  // not one of the formats we read
    kTooLarge,           // over the pixel or dimension limit
    kCorrupt,            // a known format that does not decode
    kIo,                 // writing the pyramid failed
  };
  IngestError(Kind kind, const std::string& what) : std::runtime_error(what), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

}  // namespace zoomwarp::tiles
