// `zoomwarp health [--url URL]`: GETs a running server's /healthz and exits 0 on 200, 1 on anything
// else (another status, refused, timed out). It exists for container health checks: the runtime
// image (deploy/Dockerfile) is debian:bookworm-slim, which has no curl or wget, and the binary is
// already there. Without --url it asks the server of the same container, on the port of
// --port/ZOOMWARP_PORT — the variable `serve` reads — so moving the server to another port moves
// its health check with it. Exit code 2 is a usage mistake, as for the other commands.
#include <chrono>
#include <cstdio>
#include <regex>

#include "server/commands.h"
#include "server/http_client.h"
#include "server/options.h"

namespace zoomwarp::server {

namespace {

struct Target {
  std::string host, port, path;
};

// http://HOST[:PORT][/PATH[?QUERY]]; HOST may be a bracketed IPv6 literal. No path means /healthz,
// so `--url http://replica:8080` is enough.
Target parse_url(const std::string& url) {
  static const std::regex form(R"(http://(\[[0-9A-Fa-f:.]+\]|[^/:?#\[\]]+)(?::(\d{1,5}))?(/[^#]*)?)");
  std::smatch m;
  if (!std::regex_match(url, m, form))
    throw std::invalid_argument("--url must look like http://HOST[:PORT][/PATH], not '" + url + "'");
  std::string host = m[1];
  if (host.front() == '[') host = host.substr(1, host.size() - 2);  // the resolver wants it bare
  return {host, m[2].matched ? m[2].str() : "80", m[3].matched ? m[3].str() : "/healthz"};
}

constexpr const char* kHelp =
    "usage: zoomwarp health [OPTIONS]\n"
    "\n"
    "Asks a running server whether it is alive: GETs http://127.0.0.1:PORT/healthz (or --url) and\n"
    "exits 0 if it answers 200, 1 if it answers anything else, refuses the connection or does not\n"
    "answer within --timeout; 2 on a usage mistake. For container health checks, where no curl is\n"
    "at hand: PORT is --port or ZOOMWARP_PORT, the variable `zoomwarp serve` listens on.\n\n";

}  // namespace

int health_command(const std::vector<std::string>& args) {
  Target target;
  std::string shown;  // the URL, for messages
  std::chrono::seconds timeout{};
  try {
    Options o({{"url", "", "URL to GET instead of http://127.0.0.1:PORT/healthz (no path: /healthz)"},
               {"port", "8080", "port of the server on this host, when --url is not given"},
               {"timeout", "3", "seconds to connect and get the answer before counting it as a failure"}},
              args);
    if (o.help_requested()) {
      std::printf("%s%s", kHelp, o.usage().c_str());
      return 0;
    }
    if (!o.positionals().empty()) throw std::invalid_argument("unexpected argument '" + o.positionals()[0] + "'");
    timeout = std::chrono::seconds(o.integer("timeout", 1, 3600));
    if (o.str("url").empty()) {
      target = {"127.0.0.1", std::to_string(o.integer("port", 1, 65535)), "/healthz"};
      shown = "http://127.0.0.1:" + target.port + "/healthz";
    } else {
      target = parse_url(o.str("url"));
      shown = o.str("url");
    }
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "zoomwarp health: %s\n", e.what());
    return 2;
  }
  try {
    HttpClient client(target.host, target.port, timeout);
    const HttpClientResponse r = client.get(target.path);
    if (r.status == 200) {
      std::printf("%s: 200\n", shown.c_str());  // Docker keeps a health check's output: say what was asked
      return 0;
    }
    std::fprintf(stderr, "zoomwarp health: %s answered %d\n", shown.c_str(), r.status);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "zoomwarp health: %s\n", e.what());
  }
  return 1;
}

}  // namespace zoomwarp::server
