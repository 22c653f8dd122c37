// The subcommands of the zoomwarp executable. Each takes the arguments after its name and returns
// the process exit code.
#pragma once

#include <exception>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace zoomwarp::server {

int serve_command(const std::vector<std::string>& args);
int ingest_command(const std::vector<std::string>& args);
int analyse_command(const std::vector<std::string>& args);
int store_command(const std::vector<std::string>& args);  // store copy FROM TO: folder <-> bucket
int replay_command(const std::vector<std::string>& args);
int health_command(const std::vector<std::string>& args);
int sign_command(const std::vector<std::string>& args);
int keys_command(const std::vector<std::string>& args);
int compare_command(const std::vector<std::string>& args);

// Runs a subcommand's `body` and turns what it throws into the exit code every subcommand shares:
// std::invalid_argument (a usage mistake: a bad flag or argument, an unknown image) is 2, any
// other std::exception 1, each with "zoomwarp NAME: what" on standard error. Otherwise the
// body's own code. `report_failure`, when given, tells of the other exceptions in place of that
// line: `serve` logs them as one more line of its JSON log.
int run_command(std::string_view name, const std::function<int()>& body,
                const std::function<void(const std::exception&)>& report_failure = {});

}  // namespace zoomwarp::server
