#include "warp/analysis/method_files.h"

#include <chrono>
#include <functional>
#include <map>
#include <stdexcept>

#include "tiles/parallel_jobs.h"
#include "warp/analysis/analysis_image.h"
#include "warp/analysis/deflated_payload.h"
#include "warp/analysis/derived_files.h"
#include "warp/analysis/detected_lines.h"
#include "warp/analysis/model_file.h"

namespace zoomwarp::warp {

namespace {

// What the precomputations read of a version, made once and shared by every method and kind:
// the reduced copy every map is made from and the kept line suggestions.
struct SharedInput {
  tiles::Raster analysis;
  std::vector<Segment> detected;
};
SharedInput shared_input(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model) {
  return {read_reduced_image(image, reader), suggested_lines(image, reader, model)};
}

// The line set's lines (line_set.h) as MethodInput takes them: the curator's unless none, the
// detected ones for auto only.
std::string precompute(const RetargetingMethod& method, const ImageModel& model, Saliency kind, LineSet lines,
                       const SignificanceMap& saliency, const SharedInput& shared) {
  static const std::vector<Segment> kNoLines;
  return method.precompute(MethodInput{model, kind, saliency, shared.analysis,
                                       lines == LineSet::kNone ? kNoLines : model.lines,
                                       lines == LineSet::kAuto ? shared.detected : kNoLines});
}

// Format 2 of every method's file: this magic, the method's own, the payload deflated
// (deflated_payload.h), the trailer. Format 1 — the method's magic, the payload as it is, the
// trailer — is still read.
constexpr Magic kDeflatedMagic = {'Z', 'W', 'D', 'E', 'F', 'L', '2', 0};

// Two method magics that differ only in their version digits ("ZWPFEM1" and "ZWPFEM2").
bool same_but_version(std::string_view a, std::string_view b) {
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i] != b[i] && !(digit(a[i]) && digit(b[i]))) return false;
  return true;
}

std::string sealed(const RetargetingMethod& method, const std::string& payload) {
  return with_trailer(std::string(kDeflatedMagic.begin(), kDeflatedMagic.end()) +
                      std::string(method.magic.begin(), method.magic.end()) + deflated(payload));
}

}  // namespace

std::string method_payload(const std::string& file, std::string bytes, const RetargetingMethod& method) {
  const std::string_view magic(method.magic.data(), method.magic.size());
  if (bytes.compare(0, kDeflatedMagic.size(), kDeflatedMagic.data(), kDeflatedMagic.size()) != 0) {
    // Format 1. The same magic twice: these files have always had the trailer.
    return checked_payload(file.c_str(), std::move(bytes), method.magic, method.magic).first.substr(magic.size());
  }
  const std::string body = checked_payload(file.c_str(), std::move(bytes), kDeflatedMagic, kDeflatedMagic).first;
  const std::string_view rest = std::string_view(body).substr(kDeflatedMagic.size());
  if (rest.substr(0, magic.size()) != magic) {
    if (rest.size() >= magic.size() && same_but_version(rest.substr(0, magic.size()), magic))
      throw OutdatedMethodFile(file, "another format of the method's file");
    throw ModelFileError(file, "another method's file");
  }
  return inflated(file.c_str(), rest.substr(magic.size()));
}

std::string method_file_name(const RetargetingMethod& method, Saliency saliency, LineSet lines) {
  const std::string stem = std::string(method.name) + "." + std::string(saliency_name(saliency));
  if (!method.reads_lines || lines == LineSet::kAuto) return stem + ".bin";
  return stem + (lines == LineSet::kCurator ? ".curator-lines.bin" : ".no-lines.bin");
}

std::vector<MethodFile> method_files(std::span<const Saliency> kinds, MethodSelection which) {
  std::vector<MethodFile> out;
  for (const RetargetingMethod* method : retargeting_methods())
    if (method->precompute && (which == MethodSelection::kAll || method->reads_lines))
      for (Saliency kind : kinds) out.push_back({method, kind});
  return out;
}

std::vector<MethodFile> stored_method_files(const tiles::ImageEntry& image, MethodSelection which) {
  std::vector<MethodFile> out;
  for (const MethodFile& f : method_files(kSaliencies, which))
    for (LineSet lines : kLineSets)
      if ((lines == LineSet::kAuto || f.method->reads_lines) &&
          exists(image, method_file_name(*f.method, f.saliency, lines).c_str()))
        out.push_back({f.method, f.saliency, lines});
  return out;
}

std::vector<MethodFileTiming> write_method_files(const tiles::VersionFiles& to, const tiles::ImageEntry& image,
                                                 tiles::PyramidReader& reader, const ImageModel& model,
                                                 std::span<const MethodFile> files, int threads,
                                                 std::size_t memory_budget) {
  if (files.empty()) return {};
  const SharedInput shared = shared_input(image, reader, model);
  // Each kind's map once, shared by its methods.
  std::map<Saliency, SignificanceMap> maps;
  for (const MethodFile& f : files)
    if (!maps.count(f.saliency)) maps.emplace(f.saliency, saliency_map(image, reader, model, f.saliency));
  // One job per file, each writing its file and timing it. Method-major (method_files' order): a
  // method costs about the same for every kind, so threads taking jobs in this order finish together.
  std::vector<MethodFileTiming> out(files.size());
  const std::size_t analysis_pixels = std::size_t(shared.analysis.width) * std::size_t(shared.analysis.height);
  std::vector<tiles::Job> jobs;
  for (std::size_t i = 0; i < files.size(); ++i)
    jobs.push_back({[&, i] {
      const auto start = std::chrono::steady_clock::now();
      const RetargetingMethod& method = *files[i].method;
      const MethodFile& f = files[i];
      const std::string file = method_file_name(method, f.saliency, f.lines);
      to.write(file, sealed(method, precompute(method, model, f.saliency, f.lines, maps.at(f.saliency), shared)));
      out[i] = {file, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()};
    }, files[i].method->precompute_bytes_per_pixel * analysis_pixels});
  tiles::run_jobs(jobs, threads, memory_budget);
  return out;
}

LoadedRetargeter load_retargeter(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model,
                                 const RetargetingMethod& method, Saliency saliency, LineSet lines) {
  const SignificanceMap map = saliency_map(image, reader, model, saliency);
  if (!method.precompute) return {method.load(model, map, ""), MethodSource::kNoFile, ""};
  const std::string file = method_file_name(method, saliency, lines);
  const auto precomputed = [&] { return precompute(method, model, saliency, lines, map, shared_input(image, reader, model)); };
  const auto added = [&] {
    const std::string payload = precomputed();
    const bool stored = add_derived_file(image, file.c_str(), sealed(method, payload));
    return LoadedRetargeter{method.load(model, map, payload), MethodSource::kBuiltInMemory, "", stored};
  };
  if (!exists(image, file.c_str())) return added();
  try {
    const std::string payload = method_payload(file, read_whole(image, file.c_str()), method);
    try {
      return {method.load(model, map, payload), MethodSource::kStored, ""};
    } catch (const std::runtime_error& e) {
      throw ModelFileError(file, e.what());
    }
  } catch (const OutdatedMethodFile&) {
    return added();
  } catch (const ModelFileError& damaged) {
    return {method.load(model, map, precomputed()), MethodSource::kRebuiltDamaged, damaged.what()};
  }
}

}  // namespace zoomwarp::warp
