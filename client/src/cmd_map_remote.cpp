// `stickslip map ID --server URL`: the stick-slip map of a study held by a server.
#include <memory>

#include "stickslip/client/cli.h"

namespace stickslip::client {

void add_map_command(CLI::App& app, int& exit_code) {
  auto id = std::make_shared<std::string>();
  auto server = std::make_shared<std::string>("http://127.0.0.1:8080");
  auto format = std::make_shared<std::string>("table");
  auto out = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand(
      "map", "Print a study's stick-slip map (amplitude per stage against va_over_vd and model)");
  cmd->add_option("ID", *id, "study id")->required();
  cmd->add_option("--server", *server, "stickslipd URL (token: $STICKSLIP_TOKEN)")
      ->envname("STICKSLIP_SERVER")
      ->capture_default_str();
  cmd->add_option("--format", *format, "table (stdout), csv or json")
      ->check(CLI::IsMember({"table", "csv", "json"}))
      ->capture_default_str();
  cmd->add_option("--out", *out, "file for csv/json (default: stdout)");
  cmd->callback([=, &exit_code] { exit_code = remote_map(*server, *id, *format, *out); });
}

}  // namespace stickslip::client
