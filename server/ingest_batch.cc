#include "server/ingest_batch.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <system_error>
#include <thread>

#include "tiles/source_digest.h"

namespace zoomwarp::server {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

Refusal::Kind refusal_kind(tiles::IngestError::Kind kind) {
  switch (kind) {
    case tiles::IngestError::Kind::kUnsupportedFormat: return Refusal::Kind::kUnsupportedFormat;
    case tiles::IngestError::Kind::kTooLarge: return Refusal::Kind::kTooLarge;
    case tiles::IngestError::Kind::kCorrupt: return Refusal::Kind::kCorrupt;
    case tiles::IngestError::Kind::kIo: break;
  }
  return Refusal::Kind::kFailed;
}

// Decoders' messages may span lines; an outcome is one line of the log.
std::string one_line(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

IngestOutcome ingest_one(tiles::Store& store, IngestOutcome out, const BatchOptions& options, int threads, int job,
                         IngestObserver& observer) {
  auto refuse = [&](Refusal::Kind kind, const std::string& reason) {
    out.input.refused = Refusal{kind, one_line(reason)};
    return out;
  };
  tiles::IngestOptions ingest = options.ingest;
  try {
    ingest.source_sha256 = tiles::file_sha256_hex(out.input.path);
  } catch (const std::system_error& e) {
    return refuse(Refusal::Kind::kUnreadable, "unreadable: " + e.code().message());
  } catch (const std::exception& e) {
    return refuse(Refusal::Kind::kFailed, e.what());
  }
  ingest.pyramid.threads = threads;
  // The analysis is timed apart from the pyramid: it is the part that grows with the model, not
  // with the pixels.
  if (options.ingest.analyse)
    ingest.analyse = [&out, analyse = options.ingest.analyse](const tiles::ImageEntry& staged) {
      const auto t0 = Clock::now();
      analyse(staged);
      out.analysis_seconds = seconds_since(t0);
    };
  try {
    if (auto published = store.find(out.input.id);
        !options.force && published && published->manifest.source_sha256 == ingest.source_sha256) {
      out.status = IngestOutcome::Status::kSkipped;
      out.manifest = published->manifest;
      return out;
    }
    const auto t0 = Clock::now();
    out.manifest = tiles::ingest_image(store, out.input.path, out.input.id, ingest,
                                       [&](double f) { observer.progress(job, f); });
    out.seconds = seconds_since(t0);
  } catch (const tiles::IngestError& e) {
    return refuse(refusal_kind(e.kind()), e.what());
  } catch (const std::exception& e) {
    return refuse(Refusal::Kind::kFailed, e.what());
  }
  out.status = IngestOutcome::Status::kAdded;
  out.threads = threads;
  if (options.method_timings) out.method_timings = *options.method_timings;
  return out;
}

}  // namespace

void ingest_batch(tiles::Store& store, const std::vector<IngestInput>& inputs, const BatchOptions& options,
                  IngestObserver& observer) {
  const int jobs = int(std::min<std::size_t>(std::max(options.jobs, 1), std::max<std::size_t>(inputs.size(), 1)));
  const int threads = std::max(1, options.ingest.pyramid.threads / jobs);
  std::atomic<std::size_t> next{0};
  auto run = [&](int job) {
    for (std::size_t i; (i = next++) < inputs.size();) {
      IngestOutcome out;
      out.index = i;
      out.input = inputs[i];
      if (!out.input.refused) {
        observer.started(job, out.input);
        out = ingest_one(store, std::move(out), options, threads, job, observer);
      }
      observer.finished(job, out);
    }
  };
  std::vector<std::jthread> others;
  for (int job = 1; job < jobs; ++job) others.emplace_back(run, job);
  run(0);
}

}  // namespace zoomwarp::server
