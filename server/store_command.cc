// `zoomwarp store copy FROM TO [ID...]`: copies published images from one store to another — a
// folder to a bucket and back (issue 29) — keeping each image's version, so that replicas, caches
// and ETags keyed by it stay valid. Every file of a version is copied (its pyramid, its manifest,
// the analyses it holds), then published at once in TO, then read back from TO and checked
// against the SHA-256 of what was copied: from a bucket, through a mirror of its own, so the check
// reads what the bucket holds, not the local copy just written. An image TO already holds at the
// same version is skipped, so a run cut short is resumed by running it again. Exit codes: 0 done,
// 1 some image failed (named on stderr with why), 2 usage.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

#include "server/commands.h"
#include "server/options.h"
#include "tiles/image_id.h"
#include "tiles/random_access_file.h"
#include "tiles/source_digest.h"
#include "tiles/store.h"

namespace zoomwarp::server {

namespace {

namespace fs = std::filesystem;

constexpr const char* kHelp =
    "usage: zoomwarp store copy FROM TO [ID...] [OPTIONS]\n"
    "\n"
    "Copies published images (every image of FROM, or the IDs given) into TO, keeping their\n"
    "versions. FROM and TO are store folders or s3://BUCKET/PREFIX (credentials and endpoint from\n"
    "the AWS_* variables). Each copied file is read back from TO and checked by its SHA-256.\n"
    "Images TO holds at the same version already are skipped: a run cut short is resumed by\n"
    "running it again. Exit codes: 0 done, 1 some image failed (named on stderr), 2 usage.\n\n";

// A folder of this process's own for the checking store's mirror, removed at the end.
class ScratchDir {
 public:
  ScratchDir() {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/zoomwarp-store-copy-XXXXXX";
    if (!::mkdtemp(pattern.data())) throw std::runtime_error("cannot make a temporary folder");
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

struct Copied {
  std::size_t files = 0;
  std::uintmax_t bytes = 0;
};

// Copies `image` into `to` and checks it through `check`: the same store opened again with nothing
// cached, so what is checked is read back from the store itself.
Copied copy_image(const tiles::ImageEntry& image, tiles::Store& to, tiles::Store& check) {
  const std::string staging = to.make_staging_dir();
  std::map<std::string, std::string> digests;
  Copied copied;
  try {
    for (const std::string& name : image.files->names()) {
      if (name == "manifest.json") continue;
      const std::shared_ptr<const tiles::RandomAccessFile> from = image.files->open(name);
      if (!from) throw std::runtime_error(name + ": not readable");
      const std::string staged = staging + "/" + name;
      tiles::copy_to_local_file(*from, staged);
      digests[name] = tiles::file_sha256_hex(staged);
      copied.bytes += fs::file_size(staged);
      ++copied.files;
    }
  } catch (...) {
    to.discard(staging);
    throw;
  }
  to.import(staging, image.manifest);
  const auto back = check.find(image.manifest.id);
  if (!back || back->manifest.version != image.manifest.version)
    throw std::runtime_error("not found in the destination after the copy");
  for (const auto& [name, digest] : digests) {
    const std::shared_ptr<const tiles::RandomAccessFile> file = back->files->open(name);
    if (!file) throw std::runtime_error(name + " is missing in the destination");
    if (tiles::file_sha256_hex(*file) != digest) throw std::runtime_error(name + ": SHA-256 differs in the destination");
  }
  return copied;
}

int copy_command(const std::vector<std::string>& args) {
  Options o({{"quiet", "0", "print nothing but failures", true}}, args);
  if (o.help_requested()) {
    std::printf("%s%s", kHelp, o.usage().c_str());
    return 0;
  }
  const std::vector<std::string>& p = o.positionals();
  if (p.size() < 2) throw std::invalid_argument("store copy needs FROM and TO");
  if (p[0] == p[1]) throw std::invalid_argument("FROM and TO are the same store");
  for (std::size_t i = 2; i < p.size(); ++i)
    if (!tiles::is_valid_image_id(p[i])) throw std::invalid_argument("invalid image id '" + p[i] + "'");
  const bool quiet = o.flag("quiet");
  tiles::Store from(p[0], std::chrono::milliseconds(0)), to(p[1], std::chrono::milliseconds(0));
  const ScratchDir scratch;
  tiles::Store check(p[1], std::chrono::milliseconds(0), tiles::BucketStoreOptions{.dir = scratch.path(), .disk_bytes = 0, .memory_bytes = 1u << 20, .lease = {}});

  int failed = 0;
  std::vector<std::shared_ptr<const tiles::ImageEntry>> images;
  if (p.size() == 2) images = from.list();
  for (std::size_t i = 2; i < p.size(); ++i) {
    if (auto entry = from.find(p[i])) images.push_back(entry);
    else std::fprintf(stderr, "zoomwarp store copy: %s: no such image in %s\n", p[i].c_str(), p[0].c_str()), ++failed;
  }
  for (std::size_t i = 0; i < images.size(); ++i) {
    const tiles::Manifest& m = images[i]->manifest;
    try {
      if (const auto there = to.find(m.id); there && there->manifest.version == m.version) {
        if (!quiet) std::printf("[%zu/%zu] %s@%s: there already\n", i + 1, images.size(), m.id.c_str(), m.version.c_str());
        continue;
      }
      const Copied c = copy_image(*images[i], to, check);
      if (!quiet)
        std::printf("[%zu/%zu] %s@%s: %zu files, %.1f MB, checked\n", i + 1, images.size(), m.id.c_str(),
                    m.version.c_str(), c.files + 1, double(c.bytes) / 1e6);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "zoomwarp store copy: %s: %s\n", m.id.c_str(), e.what());
      ++failed;
    }
    std::fflush(stdout);
  }
  return failed > 0 ? 1 : 0;
}

}  // namespace

int store_command(const std::vector<std::string>& args) {
  return run_command("store", [&]() -> int {
    if (args.empty() || args[0] == "--help" || args[0] == "-h") {
      std::printf("usage: zoomwarp store copy FROM TO [ID...]   (zoomwarp store copy --help)\n");
      return args.empty() ? 2 : 0;
    }
    if (args[0] == "copy") return copy_command(std::vector<std::string>(args.begin() + 1, args.end()));
    throw std::invalid_argument("unknown store command '" + args[0] + "' (there is: copy)");
  });
}

}  // namespace zoomwarp::server
