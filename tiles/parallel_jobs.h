// Independent jobs run on a few threads at once, within a memory budget: ingest's analysis (its
// maps, then the methods' precomputations, warp/analysis/) on the threads an ingest may use
// (--ingest-threads).
//
// Thread safety: the jobs must not share unsynchronised state; run_jobs itself may be called from
// any thread, each call with its own threads.
#pragma once

#include <cstddef>
#include <functional>
#include <span>

namespace zoomwarp::tiles {

struct Job {
  std::function<void()> run;
  std::size_t peak_bytes = 0;  // its estimated memory at its peak, beyond what the caller holds
};

// Runs every job on up to `threads` threads (the caller's included; 1: one after the other on the
// caller's) and returns when all have finished. Jobs run at once only while their peak_bytes sum
// to at most `memory_budget`; a job over the budget by itself runs alone. A free thread takes the
// first job, in order, that fits beside those running — so small jobs run alongside a large one
// while jobs too large to pair wait their turn. Then rethrows the first failed job's exception,
// in the jobs' order — never before all have finished, so jobs may use the caller's locals.
void run_jobs(std::span<const Job> jobs, int threads, std::size_t memory_budget);

}  // namespace zoomwarp::tiles
