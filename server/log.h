// Structured logs: one JSON object per line on stderr, e.g.
//   {"ts":"2026-11-21T21:40:00.123Z","level":"info","msg":"request","status":200,...}
// Lines are written whole with one write(2), so lines from many threads never interleave.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string_view>

namespace zoomwarp::server {

void log_event(std::string_view level, std::string_view msg, const nlohmann::json& fields);
void log_event(std::string_view level, std::string_view msg);

}  // namespace zoomwarp::server
