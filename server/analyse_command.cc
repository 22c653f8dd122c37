// `zoomwarp analyse [ID...] --store S`: computes, for published images, the warp analyses an
// ingest left for first use (issue 28: an ingest publishes the pyramid alone by default), and adds
// them to each image's version — for an operator who wants every first view fast, for a whole
// store or for some images. What a version already holds is left as it is, so a run that was cut
// short is simply run again. Exit codes: 0 done, 2 usage, 1 some image could not be analysed
// (each named on stderr with why).
#include <chrono>
#include <cstdio>
#include <string>

#include "server/commands.h"
#include "server/options.h"
#include "server/settings.h"
#include "tiles/image_id.h"
#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "warp/analysis/image_analysis.h"

namespace zoomwarp::server {

namespace {

constexpr const char* kHelp =
    "usage: zoomwarp analyse [ID...] [OPTIONS]\n"
    "\n"
    "Computes the warp analyses that published images do not hold yet and adds them to each\n"
    "image's version, so that no first view waits for one: by default every method's for both\n"
    "saliency kinds (--analyses all), or ICAZ's model and the detected lines (--analyses icaz).\n"
    "Without IDs, every image of the store. Safe while servers serve the store; a run cut short\n"
    "is resumed by running it again. Exit codes: 0 done, 1 some image failed (named on stderr),\n"
    "2 usage.\n\n";

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out.empty() ? "nothing (all there)" : out;
}

}  // namespace

int analyse_command(const std::vector<std::string>& args) {
  return run_command("analyse", [&]() -> int {
    std::vector<OptionSpec> specs = {
        {"store", "./store", "the image store: a folder, or s3://BUCKET/PREFIX (credentials and endpoint from AWS_* variables)"},
        {"analyses", "all", "what to add: all (every method, both saliency kinds) or icaz (ICAZ's model, detected lines)"},
        {"threads", "2", "threads one image's analysis uses (its methods run side by side)"},
        {"quiet", "0", "print nothing but failures", true},
    };
    for (auto& s : store_option_specs())
      if (s.name == "face-cascade") specs.push_back(s);
    Options o(specs, args);
    if (o.help_requested()) {
      std::printf("%s%s", kHelp, o.usage().c_str());
      return 0;
    }
    const auto set = warp::parse_analysis_set(o.str("analyses"));
    if (!set || *set == warp::AnalysisSet::kNone)
      throw std::invalid_argument("--analyses must be all or icaz, not '" + o.str("analyses") + "'");
    const int threads = int(o.integer("threads", 1, 256));
    for (const auto& id : o.positionals())
      if (!tiles::is_valid_image_id(id)) throw std::invalid_argument("invalid image id '" + id + "'");
    const bool quiet = o.flag("quiet");
    const AnalysisSettings analysis = analysis_settings(o);
    tiles::Store store(o.str("store"), std::chrono::milliseconds(0));
    tiles::PyramidReader reader(64 << 20);

    std::vector<std::shared_ptr<const tiles::ImageEntry>> images;
    int failed = 0;
    if (o.positionals().empty()) images = store.list();
    for (const auto& id : o.positionals()) {
      if (auto entry = store.find(id)) images.push_back(entry);
      else std::fprintf(stderr, "zoomwarp analyse: %s: no such image in the store\n", id.c_str()), ++failed;
    }
    for (std::size_t i = 0; i < images.size(); ++i) {
      const tiles::ImageEntry& image = *images[i];
      const auto t0 = std::chrono::steady_clock::now();
      try {
        const auto added = warp::add_missing_analyses(image, reader, analysis.significance, *set, threads);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (!quiet)
          std::printf("[%zu/%zu] %s: added %s in %.2f s\n", i + 1, images.size(), image.manifest.id.c_str(),
                      joined(added).c_str(), s);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "zoomwarp analyse: %s: %s\n", image.manifest.id.c_str(), e.what());
        ++failed;
      }
      std::fflush(stdout);
    }
    return failed > 0 ? 1 : 0;
  });
}

}  // namespace zoomwarp::server
