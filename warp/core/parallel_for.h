// parallel_for: one loop's independent iterations (a mesh's cells) on the cores an analysis may
// use, for the precomputations a first view waits for (issue 28: method=polyfem's model).
//
// It is ingest's job runner (tiles/parallel_jobs.h) without a memory budget. The helper threads
// are started by the calling thread for the call, not taken from a shared pool, so they run at its
// CPU priority: Linux nice values are per thread and a thread starts
// at its creator's. The background analyses, ten levels below the request workers
// (tiles/background_flights.h), keep that in their loops too; a pool made once by whichever
// thread came first would not.
//
// Thread safety: any thread may call it; `body` is called concurrently for distinct indices.
#pragma once

#include <functional>

namespace zoomwarp::warp {

// How many threads parallel_for uses: the machine's cores, at most 4 (one analysis of a
// ~200-cell mesh gains little past that, and should not take a big machine alone).
int analysis_parallelism();

// Calls body(i) once for every i in [0, n), on the calling thread and up to
// analysis_parallelism() − 1 threads started for this call, in no particular order; returns when
// every call has returned. If body throws, no further body is begun, and the exception of the
// lowest index that threw is rethrown here once every thread has stopped. Results must not depend on the order: write
// per-index slots, then combine them in index order.
void parallel_for(int n, const std::function<void(int)>& body);

}  // namespace zoomwarp::warp
