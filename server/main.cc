// zoomwarp: an image server for Interactive Content-Aware Zooming.
#include <cstdio>
#include <string>
#include <vector>

#include "server/commands.h"

namespace {
constexpr const char* kUsage =
    "usage: zoomwarp COMMAND [OPTIONS]\n"
    "\n"
    "commands:\n"
    "  serve     run the HTTP server (tiles, IIIF, Deep Zoom, REST API)\n"
    "  ingest    add an image file to the store as a tile pyramid\n"
    "  analyse   compute the warp analyses published images do not hold yet (else made on first view)\n"
    "  store     'store copy FROM TO': copy images between stores (a folder, s3://BUCKET/PREFIX)\n"
    "  replay    replay view paths against a running server (load test of /mesh and /viewport)\n"
    "  health    exit 0 if a running server answers /healthz with 200 (container health checks)\n"
    "  sign      print a URL of a private image signed to work without a key until it expires\n"
    "  keys      'keys new': make an API key and its line for the key file (serve --keys)\n"
    "  compare   render an image with several retargeting methods side by side, with metrics\n"
    "\n"
    "'zoomwarp COMMAND --help' lists a command's options; each option --some-name can also be\n"
    "set with the environment variable ZOOMWARP_SOME_NAME.\n";
}

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "-h" || args[0] == "--help" || args[0] == "help") {
    std::fputs(kUsage, args.empty() ? stderr : stdout);
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "--version") {
    std::puts("zoomwarp " ZOOMWARP_VERSION);
    return 0;
  }
  const std::string command = args[0];
  args.erase(args.begin());
  if (command == "serve") return zoomwarp::server::serve_command(args);
  if (command == "ingest") return zoomwarp::server::ingest_command(args);
  if (command == "analyse") return zoomwarp::server::analyse_command(args);
  if (command == "store") return zoomwarp::server::store_command(args);
  if (command == "replay") return zoomwarp::server::replay_command(args);
  if (command == "health") return zoomwarp::server::health_command(args);
  if (command == "sign") return zoomwarp::server::sign_command(args);
  if (command == "keys") return zoomwarp::server::keys_command(args);
  if (command == "compare") return zoomwarp::server::compare_command(args);
  std::fprintf(stderr, "zoomwarp: unknown command '%s'\n\n%s", command.c_str(), kUsage);
  return 2;
}
