// Command-line options that can also come from the environment: every flag --some-name has the
// variable ZOOMWARP_SOME_NAME; a flag on the command line wins over the variable, which wins over
// the default. Sizes accept K, M, G suffixes (powers of 1024).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace zoomwarp::server {

struct OptionSpec {
  std::string name;       // "port" -> --port, ZOOMWARP_PORT
  std::string fallback;   // default value, as text
  std::string help;
  bool is_switch = false; // takes no value on the command line (--quiet); "1"/"0" in the environment
};

class Options {
 public:
  // Parses argv (after the subcommand) and the environment. Non-option arguments are kept as
  // positionals. Throws std::invalid_argument with a user-facing message on unknown flags.
  Options(std::vector<OptionSpec> specs, const std::vector<std::string>& args);

  bool help_requested() const { return help_; }
  const std::vector<std::string>& positionals() const { return positionals_; }

  std::string str(const std::string& name) const;
  // Each throws std::invalid_argument naming the option when the value is malformed or outside
  // [lo, hi].
  std::int64_t integer(const std::string& name, std::int64_t lo, std::int64_t hi) const;
  std::uint64_t bytes(const std::string& name, std::uint64_t lo, std::uint64_t hi) const;
  bool flag(const std::string& name) const;

  // The --help text: one line per option with its variable and default.
  std::string usage() const;

  static std::string env_name(const std::string& option);

 private:
  std::vector<OptionSpec> specs_;
  std::map<std::string, std::string> values_;
  std::vector<std::string> positionals_;
  bool help_ = false;
};

}  // namespace zoomwarp::server
