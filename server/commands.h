// The subcommands of the zoomwarp executable. Each takes the arguments after its name and returns
// the process exit code.
#pragma once

#include <string>
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

}  // namespace zoomwarp::server
