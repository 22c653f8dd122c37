// `zoomwarp ingest FILE|FOLDER|-...`: publishes images' tile pyramids in the store — one file, or
// many in one process, --jobs side by side (ingest_inputs.h, ingest_batch.h, ingest_display.h).
// Exit codes: kHelp below.
#include <malloc.h>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>

#include "server/commands.h"
#include "server/ingest_batch.h"
#include "server/ingest_display.h"
#include "server/ingest_inputs.h"
#include "server/settings.h"

namespace zoomwarp::server {

namespace {

constexpr const char* kHelp =
    "usage: zoomwarp ingest FILE|FOLDER|-... [OPTIONS]\n"
    "\n"
    "Decodes each image (JPEG, PNG, TIFF or BigTIFF, WebP, JPEG 2000, HEIF or AVIF; 8 or 16\n"
    "bit; grey, RGB or RGBA; EXIF orientation applied; ICC profiles converted to sRGB) and\n"
    "publishes its tile pyramid in the store, named after its file name without the extension\n"
    "(--id names a single FILE's). Re-ingesting an id replaces the image\n"
    "atomically, also while a server is serving it; the curator's description (label, rights,\n"
    "... of its IIIF manifest; PUT /v1/images/{id}/metadata) is kept.\n"
    "\n"
    "Many images in one run: a FOLDER is walked (its regular files, sorted by path; names\n"
    "starting with '.' left out) and '-' reads paths from standard input, one per line. --jobs\n"
    "images are ingested side by side, each on --ingest-threads / --jobs threads (at least 1).\n"
    "An id already published from the same bytes (the source's SHA-256, kept in its manifest) is\n"
    "skipped, so a run that was stopped resumes where it stopped; --force ingests it again. Of\n"
    "two inputs with the same id the later is refused. A refused file stops nothing else.\n"
    "\n"
    "A line per image as it ends (ingested or skipped on stdout, refused and why on stderr), one\n"
    "progress line over the run on a terminal, and for several inputs a summary: how many were\n"
    "added, skipped and refused, and each refused file with its reason. --quiet prints only the\n"
    "ids published (added or unchanged), one per line, and the refusals.\n"
    "\n"
    "Exit codes: 0 nothing refused, 2 usage. One FILE: 3 unsupported format, 4 over the limits,\n"
    "5 corrupt or truncated, 1 anything else. Several inputs (or a FOLDER, or -): 6 some were\n"
    "refused, 1 the run could not go on (e.g. the store cannot be made).\n"
    "\n";

constexpr int kSomeRefused = 6;

// A single FILE's exit code, as before bulk ingest existed.
int exit_code(Refusal::Kind kind) {
  switch (kind) {
    case Refusal::Kind::kUnsupportedFormat: return 3;
    case Refusal::Kind::kTooLarge: return 4;
    case Refusal::Kind::kCorrupt: return 5;
    default: return 1;
  }
}

}  // namespace

int ingest_command(const std::vector<std::string>& args) {
  std::vector<OptionSpec> specs = {
      {"id", "", "image id of a single FILE (default: from the file name)"},
      {"jobs", "1", "images ingested side by side, each on --ingest-threads / --jobs threads"},
      {"force", "0", "ingest even an image already published from the same bytes", true},
      {"quiet", "0", "print only the ids published and the refusals, no progress", true},
  };
  for (auto& s : store_option_specs()) specs.push_back(s);
  for (auto& s : bucket_store_option_specs()) specs.push_back(s);
  return run_command("ingest", [&]() -> int {
    Options o(specs, args);
    if (o.help_requested()) {
      std::printf("%s%s", kHelp, o.usage().c_str());
      return 0;
    }
    const std::vector<std::string>& paths = o.positionals();
    if (paths.empty()) throw std::invalid_argument("give image files, folders, or - to read paths from standard input (see --help)");
    // One file named alone is the single-file form: its refusal is the exit code.
    const bool single = paths.size() == 1 && paths[0] != "-" && !std::filesystem::is_directory(paths[0]);
    const std::string id = o.str("id");
    if (!id.empty() && !single) throw std::invalid_argument("--id names one image: give a single file, not several, a folder or -");
    const int jobs = int(o.integer("jobs", 1, 256));

    // glibc raises its mmap threshold to the largest block freed, so the pyramid's strips and the
    // analysis's maps come to be carved from heaps that are kept when freed — worse with one heap
    // per thread, as the analysis's jobs now run side by side. A fixed 256 KiB threshold gives
    // every large block back when it is freed: on the 952 MP image peak RSS 277 -> 212 MB, for no
    // measurable time (issue 18). Only here: a server's caches are long-lived anyway.
    mallopt(M_MMAP_THRESHOLD, 256 << 10);
    // The analysis hook has one vector for the method files' timings: kept with one job only.
    std::vector<warp::MethodFileTiming> method_timings;
    std::vector<warp::MethodFileTiming>* timings = jobs == 1 ? &method_timings : nullptr;
    BatchOptions batch;
    batch.jobs = jobs;
    batch.force = o.flag("force");
    batch.method_timings = timings;
    const bool quiet = o.flag("quiet");
    // Options checked before the store is opened: a bad flag creates nothing.
    batch.ingest = ingest_options(o, analysis_settings(o).significance, timings);
    const std::vector<IngestInput> inputs = ingest_inputs(paths, std::cin, id);
    // A single file that is missing or gives no valid id is a usage error, found before the
    // store is made.
    if (single && inputs[0].refused) throw std::invalid_argument(inputs[0].path + ": " + inputs[0].refused->reason);

    tiles::Store store(o.str("store"), tiles::Store::kDefaultRecheck, bucket_store_options(o));
    IngestDisplay display(inputs.size(), jobs, quiet, store.root());
    ingest_batch(store, inputs, batch, display);
    const auto& refusals = display.refusals();
    if (single) return refusals.empty() ? 0 : exit_code(refusals[0].input.refused->kind);
    display.print_summary();
    return refusals.empty() ? 0 : kSomeRefused;
  });
}

}  // namespace zoomwarp::server
