// The images one `zoomwarp ingest` run is given, in the order it takes them: its FILE and FOLDER
// arguments, and the paths listed on standard input for an argument `-`, each with the image id
// it publishes — or the reason it is refused before any work.
//
// Threads: the command's thread, once, before any ingest starts.
#pragma once

#include <istream>
#include <optional>
#include <string>
#include <vector>

namespace zoomwarp::server {

// Why an input is not published, kept per file for the summary (and, for a single input, what
// decides `zoomwarp ingest`'s exit code).
struct Refusal {
  enum class Kind {
    kNotAFile,           // missing, or not a regular file
    kUnreadable,         // cannot be opened or read (permissions, I/O)
    kInvalidId,          // --id, or no usable id from the file name
    kIdTaken,            // an earlier input of this run maps to the same id
    kUnsupportedFormat,  // tiles::IngestError's kinds
    kTooLarge,
    kCorrupt,
    kFailed,             // writing the image or its analysis failed
  };
  Kind kind;
  std::string reason;  // one line, for people: "no such file", "id a already taken by x/a.png in this run"
};

struct IngestInput {
  std::string path;
  std::string id;                 // empty when refused
  std::optional<Refusal> refused;  // why it is refused before any work
};

// `args` are files and folders, or "-" for the paths listed in `list`, one per line (blank lines
// skipped; each a file or a folder). A folder is walked recursively: its regular files (a link to
// one included), sorted by path; names starting with '.' are left out, and links to folders are
// not followed. Anything else a folder holds, and a named path that is not a regular file, is
// refused. Each image is named `id` when given (a single input), else after its file name without
// the extension (tiles::image_id_from_filename); a later input whose id an earlier one took is
// refused, never allowed to replace it.
std::vector<IngestInput> ingest_inputs(const std::vector<std::string>& args, std::istream& list,
                                       const std::string& id = "");

}  // namespace zoomwarp::server
