// `zoomwarp keys new --id ID --role ROLE`: makes a random API key and prints it with the two lines
// that may go into the key file (README "Access", api/key_ring.h): one holding the key, one
// holding only its SHA-256 digest. Nothing is written anywhere: the operator decides where the
// key and the line go. Exit code 2 is a usage mistake, as for the other commands.
#include <cstdio>

#include "api/key_ring.h"
#include "server/commands.h"
#include "server/options.h"

namespace zoomwarp::server {

namespace {
constexpr const char* kHelp =
    "usage: zoomwarp keys new --id ID [--role ROLE]\n"
    "\n"
    "Prints a new random API key (32 bytes from the system's CSPRNG) and the lines for the key\n"
    "file of `zoomwarp serve --keys FILE`: either the one with the key or the one with only its\n"
    "SHA-256 digest (then the file does not hold the key). Clients send the key as\n"
    "'Authorization: Bearer KEY'.\n\n";
}  // namespace

int keys_command(const std::vector<std::string>& args) {
  return run_command("keys", [&]() -> int {
    Options o({{"id", "", "the key's name in logs and metrics: 1-64 characters from A-Z a-z 0-9 . _ -"},
               {"role", "curator", "reader, curator or admin"}},
              args);
    if (o.help_requested()) {
      std::printf("%s%s", kHelp, o.usage().c_str());
      return 0;
    }
    if (o.positionals().size() != 1 || o.positionals()[0] != "new")
      throw std::invalid_argument("expected 'zoomwarp keys new --id ID [--role ROLE]'");
    const std::string id = o.str("id");
    if (!api::is_valid_key_id(id)) throw std::invalid_argument("--id must be 1-64 characters from A-Z a-z 0-9 . _ -");
    const std::string_view role = api::role_name(api::parse_role(o.str("role")));
    const std::string key = api::random_key();
    const std::string prefix = id + " " + std::string(role) + " ";
    std::printf("key: %s\n\n# for the key file, either (the file holds the key):\n%s%s\n"
                "# or (the file holds only the key's SHA-256):\n%ssha256:%s\n",
                key.c_str(), prefix.c_str(), key.c_str(), prefix.c_str(), api::digest_hex(api::key_digest(key)).c_str());
    return 0;
  });
}

}  // namespace zoomwarp::server
