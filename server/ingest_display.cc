#include "server/ingest_display.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace zoomwarp::server {

namespace {

constexpr auto kRedrawEvery = std::chrono::milliseconds(100);

std::size_t terminal_columns() {
  winsize size{};
  if (::ioctl(STDERR_FILENO, TIOCGWINSZ, &size) == 0 && size.ws_col > 0) return size.ws_col;
  return 80;
}

void print_added(const IngestOutcome& o, const std::string& store_root) {
  const tiles::Manifest& m = o.manifest;
  // The methods' precomputations are part of the warp analysis: each one's share.
  std::string methods;
  for (const auto& t : o.method_timings) {
    char took[32];
    std::snprintf(took, sizeof took, " %.2f s", t.seconds);
    methods += (methods.empty() ? "; " : ", ") + t.file + took;
  }
  std::printf("ingested %s: %dx%d, %d levels, version %s, in %s; %.2f s on %d threads (pyramid %.2f s, "
              "warp analysis %.2f s%s)\n",
              m.id.c_str(), m.width, m.height, m.levels, m.version.c_str(), store_root.c_str(), o.seconds, o.threads,
              o.seconds - o.analysis_seconds, o.analysis_seconds, methods.c_str());
}

void print_refused(const IngestOutcome& o, FILE* to, const char* prefix) {
  std::fprintf(to, "%s%s: %s\n", prefix, o.input.path.c_str(), o.input.refused->reason.c_str());
}

}  // namespace

IngestDisplay::IngestDisplay(std::size_t inputs, int jobs, bool quiet, std::string store_root)
    : inputs_(inputs),
      quiet_(quiet),
      bar_(!quiet && ::isatty(STDERR_FILENO)),
      store_root_(std::move(store_root)),
      jobs_(std::size_t(std::max(jobs, 1))) {}

void IngestDisplay::started(int job, const IngestInput& input) {
  std::lock_guard lock(mu_);
  jobs_[job] = {input.id, 0};
  draw_bar();
}

void IngestDisplay::progress(int job, double fraction) {
  std::lock_guard lock(mu_);
  jobs_[job].fraction = fraction;
  if (std::chrono::steady_clock::now() - drawn_at_ >= kRedrawEvery) draw_bar();
}

void IngestDisplay::finished(int job, const IngestOutcome& outcome) {
  std::lock_guard lock(mu_);
  jobs_[job] = {};
  ++finished_;
  clear_bar();
  switch (outcome.status) {
    case IngestOutcome::Status::kAdded:
      ++added_;
      if (quiet_) std::printf("%s\n", outcome.manifest.id.c_str());
      else print_added(outcome, store_root_);
      break;
    case IngestOutcome::Status::kSkipped:
      ++skipped_;
      if (quiet_) std::printf("%s\n", outcome.manifest.id.c_str());
      else
        std::printf("skipped %s: %s unchanged, version %s kept\n", outcome.manifest.id.c_str(),
                    outcome.input.path.c_str(), outcome.manifest.version.c_str());
      break;
    case IngestOutcome::Status::kRefused:
      print_refused(outcome, stderr, "zoomwarp ingest: refused ");
      refusals_.insert(std::upper_bound(refusals_.begin(), refusals_.end(), outcome,
                                        [](const IngestOutcome& a, const IngestOutcome& b) { return a.index < b.index; }),
                       outcome);
      break;
  }
  std::fflush(stdout);  // before the bar is drawn again, and so that a log shows each image as it ends
  if (finished_ < inputs_) draw_bar();  // after the last image the terminal is left clean
}

void IngestDisplay::print_summary() {
  std::lock_guard lock(mu_);
  if (quiet_) return;
  std::printf("%zu images: %zu added, %zu skipped (unchanged), %zu refused\n", inputs_, added_, skipped_,
              refusals_.size());
  for (const IngestOutcome& o : refusals_) print_refused(o, stdout, "  ");
  std::fflush(stdout);
}

void IngestDisplay::draw_bar() {
  if (!bar_) return;
  double done = double(finished_);
  std::string current;
  for (const Job& j : jobs_) {
    if (j.id.empty()) continue;
    done += j.fraction;
    current += (current.empty() ? "  current: " : ", ") + j.id;
  }
  char head[96];
  std::snprintf(head, sizeof head, "[%zu/%zu] %3d%%", finished_, inputs_,
                int(100 * done / double(std::max<std::size_t>(inputs_, 1))));
  std::string line = head;
  if (!refusals_.empty()) line += "  " + std::to_string(refusals_.size()) + " refused";
  line += current;
  // A line wider than the terminal would wrap, and "\r" would then redraw only its last row.
  line.resize(std::min(line.size(), terminal_columns() - 1));
  std::fprintf(stderr, "\r%s\033[K", line.c_str());
  std::fflush(stderr);
  drawn_at_ = std::chrono::steady_clock::now();
  bar_shown_ = true;
}

void IngestDisplay::clear_bar() {
  if (!bar_shown_) return;
  std::fputs("\r\033[K", stderr);
  std::fflush(stderr);
  bar_shown_ = false;
}

}  // namespace zoomwarp::server
