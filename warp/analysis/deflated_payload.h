// A model file's payload compressed with DEFLATE (libdeflate), the one compression every model
// file kind uses (significance.bin and gbvs.bin in compact_map.h, the methods' files in
// method_files.h): the payload's size as a little-endian uint64, then the raw DEFLATE stream.
// The file's model_file.h trailer is over these bytes, so damage is found before inflating.
//
// Thread safety: free functions; each call has its own (de)compressor, safe to call concurrently.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace zoomwarp::warp {

// The largest payload inflated() accepts: every file of a ≤ 1024 px analysis image is well
// below it, and a damaged size field cannot make a reader allocate more.
inline constexpr std::size_t kMaxInflatedBytes = std::size_t(1) << 30;

// `payload` deflated, its size ahead of it.
std::string deflated(std::string_view payload);

// What deflated() wrote, back. Throws ModelFileError(file, …) when the stream does not inflate
// to exactly the size it states, or states more than `max_bytes`.
std::string inflated(const char* file, std::string_view bytes, std::size_t max_bytes = kMaxInflatedBytes);

}  // namespace zoomwarp::warp
