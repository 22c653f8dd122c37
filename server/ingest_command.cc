// `zoomwarp ingest FILE`: builds an image's pyramid into the store, with a progress bar on a
// terminal. Exit codes: 0 done, 2 usage, 3 unsupported format, 4 over the limits, 5 corrupt
// image, 1 anything else.
#include <malloc.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "server/commands.h"
#include "server/settings.h"
#include "tiles/image_id.h"
#include "tiles/ingest.h"

namespace zoomwarp::server {

namespace {

void draw_progress(const std::string& id, double fraction) {
  constexpr int kWidth = 30;
  const int filled = int(fraction * kWidth + 0.5);
  std::fprintf(stderr, "\r%s [%s%s] %3d%%", id.c_str(), std::string(filled, '#').c_str(),
               std::string(kWidth - filled, ' ').c_str(), int(fraction * 100 + 0.5));
  std::fflush(stderr);
}

}  // namespace

int ingest_command(const std::vector<std::string>& args) {
  std::vector<OptionSpec> specs = {
      {"id", "", "image id (default: from the file name)"},
      {"quiet", "0", "print only the id, no progress", true},
  };
  for (auto& s : store_option_specs()) specs.push_back(s);
  try {
    Options o(specs, args);
    if (o.help_requested()) {
      std::printf("usage: zoomwarp ingest FILE [OPTIONS]\n\n"
                  "Decodes FILE (JPEG, PNG, TIFF or WebP; 8 or 16 bit; grey, RGB or RGBA; EXIF\n"
                  "orientation applied) and publishes its tile pyramid in the store. Re-ingesting an\n"
                  "id replaces the image atomically, also while a server is serving it.\n\n%s",
                  o.usage().c_str());
      return 0;
    }
    if (o.positionals().size() != 1) throw std::invalid_argument("give exactly one image file (see --help)");
    const std::string file = o.positionals()[0];
    if (!std::filesystem::is_regular_file(file)) throw std::invalid_argument("no such file: " + file);
    std::string id = o.str("id");
    if (id.empty()) id = tiles::image_id_from_filename(file);
    if (!tiles::is_valid_image_id(id))
      throw std::invalid_argument("invalid image id '" + id +
                                  "': use 1-128 characters from A-Z a-z 0-9 . _ - starting with a letter or digit");
    const bool quiet = o.flag("quiet");
    const bool bar = !quiet && ::isatty(STDERR_FILENO);

    // glibc raises its mmap threshold to the largest block freed, so the pyramid's strips and the
    // analysis's maps come to be carved from heaps that are kept when freed — worse with one heap
    // per thread, as the analysis's jobs now run side by side. A fixed 256 KiB threshold gives
    // every large block back when it is freed: on the 952 MP image peak RSS 277 -> 212 MB, for no
    // measurable time (issue 18). Only here: a server's caches are long-lived anyway.
    mallopt(M_MMAP_THRESHOLD, 256 << 10);
    // Time the warp engine's analysis apart from the pyramid: it is the part that grows with
    // the model, not with the pixels.
    using Clock = std::chrono::steady_clock;
    std::vector<warp::MethodFileTiming> method_timings;
    // Options checked before the store is opened: a bad flag creates nothing.
    tiles::IngestOptions options = ingest_options(o, analysis_settings(o).significance, &method_timings);
    tiles::Store store(o.str("store"));
    tiles::ProgressFn progress;
    if (bar) progress = [&](double f) { draw_progress(id, f); };
    double analysis_s = 0;
    options.analyse = [&, analyse = options.analyse](const tiles::ImageEntry& staged) {
      const auto t0 = Clock::now();
      analyse(staged);
      analysis_s = std::chrono::duration<double>(Clock::now() - t0).count();
    };
    const auto t0 = Clock::now();
    tiles::Manifest m = tiles::ingest_image(store, file, id, options, progress);
    const double total_s = std::chrono::duration<double>(Clock::now() - t0).count();
    if (bar) std::fputc('\n', stderr);
    if (quiet) std::printf("%s\n", m.id.c_str());
    else {
      // The methods' precomputations are part of the warp analysis: each one's share.
      std::string methods;
      for (const auto& t : method_timings) {
        char took[32];
        std::snprintf(took, sizeof took, " %.2f s", t.seconds);
        methods += (methods.empty() ? "; " : ", ") + t.file + took;
      }
      std::printf("ingested %s: %dx%d, %d levels, version %s, in %s; %.2f s on %d threads (pyramid %.2f s, "
                  "warp analysis %.2f s%s)\n",
                  m.id.c_str(), m.width, m.height, m.levels, m.version.c_str(), store.root().c_str(), total_s,
                  options.pyramid.threads, total_s - analysis_s, analysis_s, methods.c_str());
    }
    return 0;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "zoomwarp ingest: %s\n", e.what());
    return 2;
  } catch (const tiles::IngestError& e) {
    std::fprintf(stderr, "\nzoomwarp ingest: %s\n", e.what());
    switch (e.kind()) {
      case tiles::IngestError::Kind::kUnsupportedFormat: return 3;
      case tiles::IngestError::Kind::kTooLarge: return 4;
      case tiles::IngestError::Kind::kCorrupt: return 5;
      case tiles::IngestError::Kind::kIo: return 1;
    }
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "zoomwarp ingest: %s\n", e.what());
    return 1;
  }
}

}  // namespace zoomwarp::server
