// An exclusive lock across the processes that share a bucket (issue 42: replicas lost curator
// edits because a bucket store's lock on an image was per process): a lease, one small object
// per locked name, that the holder writes and every other process waits out.
//
// Why a lease and not a conditional write: OpenStack Swift's s3api answers 501 to a PUT with
// `If-None-Match: *`, and AWS S3 took it only in 2024, so the one mechanism that holds on every
// S3-compatible store is built from plain GET, PUT and DELETE of one key, which S3 (strongly
// consistent since December 2020) and Swift order for a single key. Acquiring (acquire_lease):
//
//   1. GET the lease. Held by someone else and not expired (by this host's clock, plus `skew`):
//      wait `poll` and go back to 1, until the deadline.
//   2. PUT our own: a token no other acquisition uses, and the time it expires (now + `ttl`).
//   3. Wait `settle`, then GET it again: still ours, it is held; another's, go back to 1.
//
// Two processes cannot both hold it: for both to read their own lease at step 3, one's PUT
// must come after the other's step-3 GET, so `settle` after its own step-1 GET saw nothing
// live. That holds while no process stalls for `settle` between its step-1 GET and step-2 PUT
// (two consecutive requests on one thread: milliseconds) and clocks agree within `skew` (NTP).
// The holder does its work within `ttl` − `skew` (lease_time_left says how much is left: check
// it before the write that must be covered) and releases; a holder that dies is waited out for
// `ttl` + `skew`.
//
// Threads: the functions hold no state; call them from any thread. One process's threads are
// expected to serialise among themselves first (BucketStore's per-id mutex), so that a lease
// is taken once per process, not raced for by its own threads.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>

namespace zoomwarp::tiles {

struct LeaseTiming {
  std::chrono::milliseconds ttl{10'000};   // how long a lease lasts without its holder
  std::chrono::milliseconds settle{300};   // step 3's wait: longer than a GET-then-PUT takes
  std::chrono::milliseconds skew{2'000};   // how far two hosts' clocks may disagree
  std::chrono::milliseconds poll{50};      // how often a waiter looks again
};

// The one key the lease lives in: read, written and removed by whoever holds the bucket.
struct LeaseObject {
  std::function<std::optional<std::string>()> get;
  std::function<void(const std::string&)> put;
  std::function<void()> remove;
};

struct HeldLease {
  std::string token;
  std::int64_t expires_ms = 0;  // Unix milliseconds, by this host's clock
};

// The lease is held by another process past `deadline` (steady clock): `holder` names it.
struct LeaseBusy : std::runtime_error {
  LeaseBusy(const std::string& what, std::string holder) : std::runtime_error(what), holder(std::move(holder)) {}
  std::string holder;
};

// Steps 1–3 above; throws LeaseBusy at the deadline, and whatever the object's calls throw.
HeldLease acquire_lease(const LeaseObject& lease, const LeaseTiming& timing,
                        std::chrono::steady_clock::time_point deadline);

// How long the holder may still act as the holder: the time to expiry less `skew` (negative once
// another process may take it).
std::chrono::milliseconds lease_time_left(const HeldLease& held, const LeaseTiming& timing);

// Removes the lease if it is still surely ours (time left); otherwise leaves it to expire, since
// it may already be another's. Never throws: a lease not removed is waited out.
void release_lease(const LeaseObject& lease, const HeldLease& held, const LeaseTiming& timing);

// The lease object's text ("TOKEN EXPIRES_MS\n") and its reading; nullopt for other text.
std::string lease_text(const HeldLease& held);
std::optional<HeldLease> parse_lease(const std::string& text);

}  // namespace zoomwarp::tiles
