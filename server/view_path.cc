#include "server/view_path.h"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace zoomwarp::server {

namespace {

using nlohmann::json;

// `range` says [lo, hi] in words, for the message.
double number(const json& line, const char* key, double lo, double hi, const char* range) {
  if (!line.contains(key)) throw std::invalid_argument(std::string("missing \"") + key + "\"");
  const json& v = line[key];
  if (!v.is_number() || !(v.get<double>() >= lo && v.get<double>() <= hi))
    throw std::invalid_argument(std::string("\"") + key + "\" must be a number " + range + ", not " + v.dump());
  return v.get<double>();
}

int screen_size(const json& line, const char* key, int fallback) {
  if (!line.contains(key)) return fallback;
  const json& v = line[key];
  if (!v.is_number_integer() || v.get<long long>() < 16 || v.get<long long>() > 4096)
    throw std::invalid_argument(std::string("\"") + key + "\" must be a whole number from 16 to 4096, not " + v.dump());
  return v.get<int>();
}

ViewAction parse_action(const std::string& text) {
  const json line = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!line.is_object()) throw std::invalid_argument("not a JSON object");
  for (const auto& [key, value] : line.items())
    if (key != "action" && key != "zoom" && key != "cx" && key != "cy" && key != "w" && key != "h")
      throw std::invalid_argument("unknown key \"" + key + "\"");
  ViewAction a;
  const json action = line.value("action", json());
  if (action == "zoom") a.kind = ViewAction::Kind::kZoom;
  else if (action == "pan") a.kind = ViewAction::Kind::kPan;
  else throw std::invalid_argument("\"action\" must be \"zoom\" or \"pan\", not " + action.dump());
  a.zoom = number(line, "zoom", 0, 1, "from 0 to 1");
  // The upper bounds are the image's size, checked once the image is known.
  a.cx = number(line, "cx", 0, HUGE_VAL, "of at least 0");
  a.cy = number(line, "cy", 0, HUGE_VAL, "of at least 0");
  a.width = screen_size(line, "w", a.width);
  a.height = screen_size(line, "h", a.height);
  return a;
}

bool skipped(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  return first == std::string::npos || line[first] == '#';
}

}  // namespace

std::string_view kind_name(ViewAction::Kind kind) { return kind == ViewAction::Kind::kZoom ? "zoom" : "pan"; }

std::vector<ViewAction> read_view_path(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::invalid_argument("cannot read view path " + file);
  std::vector<ViewAction> actions;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (skipped(line)) continue;
    const std::string where = file + ":" + std::to_string(number);
    try {
      actions.push_back(parse_action(line));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(where + ": " + e.what());
    }
    actions.back().where = where;
  }
  if (actions.empty()) throw std::invalid_argument("view path " + file + " holds no action");
  return actions;
}

}  // namespace zoomwarp::server
