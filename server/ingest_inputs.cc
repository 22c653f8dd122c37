#include "server/ingest_inputs.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <system_error>

#include "tiles/image_id.h"

namespace zoomwarp::server {

namespace {

namespace fs = std::filesystem;

IngestInput refused(const fs::path& path, Refusal::Kind kind, std::string reason) {
  return {path.string(), "", Refusal{kind, std::move(reason)}};
}

// A path that should be a regular file (named, listed, or met in a folder).
IngestInput file_input(const fs::path& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);  // follows links
  if (status.type() == fs::file_type::not_found) return refused(path, Refusal::Kind::kNotAFile, "no such file");
  if (ec) return refused(path, Refusal::Kind::kUnreadable, "unreadable: " + ec.message());
  if (!fs::is_regular_file(status)) return refused(path, Refusal::Kind::kNotAFile, "not a regular file");
  return {path.string(), "", std::nullopt};
}

bool hidden(const fs::path& path) { return path.filename().string().starts_with('.'); }

void walk(const fs::path& folder, std::vector<IngestInput>& out) {
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    if (hidden(it->path())) continue;
    std::error_code type_ec;
    if (it->symlink_status(type_ec).type() == fs::file_type::directory) {
      walk(it->path(), out);
    } else if (it->is_symlink(type_ec) && it->is_directory(type_ec)) {
      continue;  // not followed: a link can lead back up the tree
    } else {
      out.push_back(file_input(it->path()));
    }
  }
  if (ec) out.push_back(refused(folder, Refusal::Kind::kUnreadable, "unreadable folder: " + ec.message()));
}

// One argument or listed line: a folder's files sorted by path, or the path itself.
void add_path(const std::string& path, std::vector<IngestInput>& out) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) {
    out.push_back(file_input(path));
    return;
  }
  std::vector<IngestInput> files;
  walk(path, files);
  std::sort(files.begin(), files.end(), [](const IngestInput& a, const IngestInput& b) { return a.path < b.path; });
  std::move(files.begin(), files.end(), std::back_inserter(out));
}

}  // namespace

std::vector<IngestInput> ingest_inputs(const std::vector<std::string>& args, std::istream& list, const std::string& id) {
  std::vector<IngestInput> inputs;
  for (const std::string& arg : args) {
    if (arg != "-") {
      add_path(arg, inputs);
      continue;
    }
    for (std::string line; std::getline(list, line);) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (!line.empty()) add_path(line, inputs);
    }
  }
  std::map<std::string, std::string> taken;  // id -> the path that took it
  for (IngestInput& in : inputs) {
    if (in.refused) continue;
    const std::string name = id.empty() ? tiles::image_id_from_filename(in.path) : id;
    if (name.empty() || !tiles::is_valid_image_id(name)) {
      in.refused = Refusal{Refusal::Kind::kInvalidId,
                           (id.empty() ? std::string("no image id can be made from the file name")
                                       : "invalid image id '" + id + "'") +
                               ": use 1-128 characters from A-Z a-z 0-9 . _ - starting with a letter or digit"};
    } else if (auto [first, added] = taken.emplace(name, in.path); !added) {
      in.refused = Refusal{Refusal::Kind::kIdTaken, "id " + name + " already taken by " + first->second + " in this run"};
    } else {
      in.id = name;
    }
  }
  return inputs;
}

}  // namespace zoomwarp::server
