#include "tiles/image_id.h"

#include <cctype>

namespace zoomwarp::tiles {

namespace {
bool id_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
}
}  // namespace

bool is_valid_image_id(std::string_view id) {
  if (id.empty() || id.size() > kMaxImageIdLength) return false;
  if (!std::isalnum(static_cast<unsigned char>(id.front()))) return false;
  for (char c : id)
    if (!id_char(c)) return false;
  return id.find("..") == std::string_view::npos;
}

std::string image_id_from_filename(std::string_view filename) {
  if (auto slash = filename.find_last_of('/'); slash != std::string_view::npos)
    filename.remove_prefix(slash + 1);
  if (auto dot = filename.find_last_of('.'); dot != std::string_view::npos && dot > 0)
    filename = filename.substr(0, dot);
  std::string id;
  for (char c : filename) {
    char out = id_char(c) ? c : '_';
    if (out == '_' && !id.empty() && id.back() == '_') continue;  // collapse runs of junk
    if (out == '.' && !id.empty() && id.back() == '.') continue;
    id.push_back(out);
  }
  while (!id.empty() && !std::isalnum(static_cast<unsigned char>(id.front()))) id.erase(id.begin());
  while (!id.empty() && (id.back() == '_' || id.back() == '.')) id.pop_back();
  if (id.size() > kMaxImageIdLength) id.resize(kMaxImageIdLength);
  return is_valid_image_id(id) ? id : std::string();
}

}  // namespace zoomwarp::tiles
