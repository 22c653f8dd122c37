#include "server/commands.h"

#include <cstdio>
#include <stdexcept>

namespace zoomwarp::server {

int run_command(std::string_view name, const std::function<int()>& body,
                const std::function<void(const std::exception&)>& report_failure) {
  const auto fail = [&](const std::exception& e, int code) {
    std::fprintf(stderr, "zoomwarp %.*s: %s\n", int(name.size()), name.data(), e.what());
    return code;
  };
  try {
    return body();
  } catch (const std::invalid_argument& e) {
    return fail(e, 2);
  } catch (const std::exception& e) {
    if (!report_failure) return fail(e, 1);
    report_failure(e);
    return 1;
  }
}

}  // namespace zoomwarp::server
