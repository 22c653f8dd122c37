// Garbage collection by supersede time (issue 42): a version stays readable for the grace period
// after it stopped being its image's published version — replaced or deleted — whatever its age.
// A replica that read the pointer trusts that version for up to --store-recheck-ms, so the grace
// (at least that long, serve refuses less) is measured from the moment the version left the
// pointer, not from its creation: a version published an hour ago and replaced now was removed by
// the next pass, and a replica still trusting it answered 500 for every tile it had not cached.
//
// Both store backends keep, beside images/ and versions/,
//   superseded/ID@VERSION   the time (ms since the Unix epoch, decimal) at which VERSION stopped
//                           being ID's published version, or — where no process wrote that (one
//                           that died between moving the pointer and writing it, replicas racing
//                           on one bucket's pointer, a store from before this) — at which garbage
//                           collection first found it unnamed.
// A commit or delete writes the mark of the version it unpublishes before it moves the pointer
// (a mark on a version still named is harmless: collection skips named versions and drops their
// marks). Collection removes an unnamed version only once its mark is older than the grace, and
// never one younger than the grace (a commit in flight has not written its pointer yet).
//
// Plain functions; thread-safe.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

namespace zoomwarp::tiles {

inline constexpr const char* kSupersededFolder = "superseded";

// Now, in ms since the Unix epoch: what a mark holds.
std::int64_t unix_ms_now();

// A mark's body, and its time back from a body (none: not a mark's).
std::string superseded_mark(std::int64_t unix_ms);
std::optional<std::int64_t> parse_superseded_mark(const std::string& body);

// What collection does with a version directory.
enum class Collect {
  kKeep,    // named, or younger than the grace, or not yet unnamed for the grace
  kMark,    // unnamed and never marked: mark it now, decide in a later pass
  kRemove,  // unnamed for the grace (any unnamed one, for a grace of 0) and older than it: remove it and its mark
};
// `named`: a pointer names it now; `superseded_ms`: its mark's time; `created_ms`: its creation
// time where known.
Collect collect_verdict(bool named, std::optional<std::int64_t> superseded_ms, std::optional<std::int64_t> created_ms,
                        std::int64_t now_ms, std::chrono::seconds grace);

}  // namespace zoomwarp::tiles
