// The ingests of one `zoomwarp ingest` run: its inputs (ingest_inputs.h) taken in order by `jobs`
// threads, each image on its share of the ingest threads, each ending added, skipped or refused.
//
// An image is skipped when its id is already published from the same source bytes (the SHA-256
// recorded in its manifest), so a run that was stopped resumes where it stopped; `force` ingests
// it again anyway. The digest is taken before the ingest, from a first read of the file (the
// decoder's read then comes from the page cache): a file rewritten in between publishes its new
// pixels under the old digest, and the next run re-ingests it only with --force.
//
// Memory grows with `jobs`, not with the number of inputs: an image's pixels live only in its
// ingest, and its outcome is handed to the observer and then dropped.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "server/ingest_inputs.h"
#include "tiles/ingest.h"
#include "tiles/store.h"
#include "warp/analysis/method_files.h"

namespace zoomwarp::server {

struct IngestOutcome {
  enum class Status { kAdded, kSkipped, kRefused };
  Status status = Status::kRefused;
  std::size_t index = 0;  // its place among the inputs
  IngestInput input;      // refused: input.refused says why
  // Added: the version published; skipped: the one already published from the same bytes.
  tiles::Manifest manifest;
  // Added: how long it took and on how many pyramid threads; the warp analysis's share, and each
  // method file's when known (one job at a time, see BatchOptions::method_timings).
  double seconds = 0;
  double analysis_seconds = 0;
  int threads = 0;
  std::vector<warp::MethodFileTiming> method_timings;
};

// What a batch tells while it runs. Threads: each call comes from the job thread doing the work,
// several jobs at once; `job` (0 … jobs-1) says which.
class IngestObserver {
 public:
  virtual ~IngestObserver() = default;
  virtual void started(int job, const IngestInput& input) = 0;
  virtual void progress(int job, double fraction) = 0;  // 0…1 of the image `job` is on
  virtual void finished(int job, const IngestOutcome& outcome) = 0;
};

struct BatchOptions {
  // The ingest settings of every image; each gets max(1, ingest.pyramid.threads / jobs) pyramid
  // threads. The analysis hook is wrapped to time it; it keeps the thread count it was made with.
  tiles::IngestOptions ingest;
  int jobs = 1;        // images side by side (fewer when there are fewer inputs)
  bool force = false;  // ingest even what is published from the same bytes
  // Where the analysis hook writes the method files' timings (settings.h, ingest_options): one
  // vector for the whole run, so read only when jobs is 1; null otherwise.
  const std::vector<warp::MethodFileTiming>* method_timings = nullptr;
};

// Ingests every input (those refused up front are reported as refused without any work) and
// returns when all are done. No input's failure stops another. The jobs that run beside the
// caller's thread are started here and joined before returning.
void ingest_batch(tiles::Store& store, const std::vector<IngestInput>& inputs, const BatchOptions& options,
                  IngestObserver& observer);

}  // namespace zoomwarp::server
