// What `zoomwarp ingest` tells while it runs and when it is done.
//
// - A line per image as it finishes, so that a log shows the progress: "ingested ID: …" (the line
//   a single-file ingest has always printed) or "skipped ID: …" on stdout, and a refusal,
//   "zoomwarp ingest: refused FILE: REASON", on stderr. With `quiet`: only the ids published
//   (added, or already there from the same bytes) on stdout, the refusals still on stderr.
// - On a terminal (stderr is a tty) and not `quiet`: one progress line over the whole run on
//   stderr, "[12/60] 20%  3 refused  current: a, b" (finished/inputs, the work done counting each
//   running image's own progress, the images being ingested), redrawn in place at most ten times
//   a second, cut to the terminal's width, cleared around each finished image's line and gone
//   once the last image is done.
// - The summary, when asked for at the end.
//
// Threads: the IngestObserver calls come from every job's thread at once; one mutex orders the
// output. print_summary() and refusals() after the batch, from the command's thread.
#pragma once

#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>
#include <vector>

#include "server/ingest_batch.h"

namespace zoomwarp::server {

class IngestDisplay : public IngestObserver {
 public:
  IngestDisplay(std::size_t inputs, int jobs, bool quiet, std::string store_root);

  void started(int job, const IngestInput& input) override;
  void progress(int job, double fraction) override;
  void finished(int job, const IngestOutcome& outcome) override;

  // "N images: A added, S skipped (unchanged), R refused" and each refusal's file and reason, in
  // the inputs' order, on stdout; nothing when quiet.
  void print_summary();
  // The refused inputs so far, in the inputs' order.
  const std::vector<IngestOutcome>& refusals() const { return refusals_; }

 private:
  struct Job {
    std::string id;         // empty: between images
    double fraction = 0;
  };
  void draw_bar();   // holding mu_
  void clear_bar();  // holding mu_

  const std::size_t inputs_;
  const bool quiet_;
  const bool bar_;
  const std::string store_root_;
  std::mutex mu_;
  std::vector<Job> jobs_;
  std::size_t added_ = 0, skipped_ = 0, finished_ = 0;
  std::vector<IngestOutcome> refusals_;
  std::chrono::steady_clock::time_point drawn_at_{};
  bool bar_shown_ = false;
};

}  // namespace zoomwarp::server
