// Names that no other process, thread or host picks: image versions, staging folders,
// temporaries. Thread-safe.
#pragma once

#include <cstdint>
#include <string>

namespace zoomwarp::tiles {

// `v` as `digits` lower-case hexadecimal digits (the lowest ones, zero-padded).
std::string hex(std::uint64_t v, int digits);
// 64 random bits, from a generator seeded per thread with the pid and the time.
std::uint64_t random_u64();
// This host's name with dots made underscores (a file-name component); "host" when unknown.
std::string host_name();
// HOST.PID.RANDOM: a staging folder's or temporary's name, whose owner can be found alive or dead.
std::string owned_unique_name();

}  // namespace zoomwarp::tiles
