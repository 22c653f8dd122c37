// Independent jobs run on a few threads at once: ingest's analysis (its maps, then the methods'
// precomputations, warp/analysis/) on the threads an ingest may use (--ingest-threads).
//
// Thread safety: the jobs must not share unsynchronised state; run_jobs itself may be called from
// any thread, each call with its own threads.
#pragma once

#include <functional>
#include <span>

namespace zoomwarp::tiles {

// Runs every job, on up to `threads` threads (the caller's included; 1: one after the other on
// the caller's), and returns when all have finished. Then rethrows the first failed job's
// exception, in the jobs' order — never before all have finished, so jobs may use the caller's
// locals.
void run_jobs(std::span<const std::function<void()>> jobs, int threads);

}  // namespace zoomwarp::tiles
