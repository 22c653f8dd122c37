#include "tiles/superseded_versions.h"

#include <cctype>

namespace zoomwarp::tiles {

std::int64_t unix_ms_now() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string superseded_mark(std::int64_t unix_ms) { return std::to_string(unix_ms) + "\n"; }

std::optional<std::int64_t> parse_superseded_mark(const std::string& body) {
  std::int64_t ms = 0;
  std::size_t digits = 0;
  for (char c : body) {
    if (c == '\n' && digits > 0) break;
    if (!std::isdigit(static_cast<unsigned char>(c)) || digits == 18) return std::nullopt;
    ms = ms * 10 + (c - '0');
    ++digits;
  }
  if (digits == 0) return std::nullopt;
  return ms;
}

Collect collect_verdict(bool named, std::optional<std::int64_t> superseded_ms, std::optional<std::int64_t> created_ms,
                        std::int64_t now_ms, std::chrono::seconds grace) {
  if (named) return Collect::kKeep;
  const std::int64_t grace_ms = std::chrono::duration_cast<std::chrono::milliseconds>(grace).count();
  if (created_ms && now_ms - *created_ms < grace_ms) return Collect::kKeep;
  if (!superseded_ms) return grace_ms <= 0 ? Collect::kRemove : Collect::kMark;
  return now_ms - *superseded_ms < grace_ms ? Collect::kKeep : Collect::kRemove;
}

}  // namespace zoomwarp::tiles
