#pragma once
// The `stickslip` command line. Subcommands register themselves on a CLI11 app; main() only
// calls run(). Exit codes: 0 success, 1 failure, 2 bad input (message on stderr).
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "stickslip/engine/params.h"

namespace stickslip::client {

enum ExitCode : int { kOk = 0, kFailure = 1, kBadInput = 2, kUnreachable = 3, kStudyFailed = 4 };

/// Parses argv and runs the chosen subcommand; returns the process exit code.
int run(int argc, char** argv);

/// --effect ID and --effect-param NAME=VALUE (repeatable) on a subcommand (simulate, synth).
void add_effect_options(CLI::App& cmd, std::string& effect, std::vector<std::string>& params);
/// Applies them to cfg: the effect id, then each parameter with set_parameter. Throws
/// InvalidParameter naming the field and the value (also for a malformed NAME=VALUE).
void apply_effect_options(const std::string& effect, const std::vector<std::string>& params,
                          engine::SimConfig& cfg);

/// Subcommand registration (one function per command family).
void add_simulate_command(CLI::App& app, int& exit_code);
void add_synth_command(CLI::App& app, int& exit_code);
void add_diagnose_command(CLI::App& app, int& exit_code);
void add_validate_command(CLI::App& app, int& exit_code);  ///< `validate DIAGNOSIS MANIFEST`
void add_table_command(CLI::App& app, int& exit_code);
void add_study_command(CLI::App& app, int& exit_code);
void add_store_command(CLI::App& app, int& exit_code);  ///< `store check DB`
void add_map_command(CLI::App& app, int& exit_code);  ///< `map` (local --db, or --server) and `rmse`
void add_indices_command(CLI::App& app, int& exit_code);
void add_report_command(CLI::App& app, int& exit_code);
/// submit, status, wait, runs, cancel, list: commands that talk to a stickslipd server.
void add_remote_commands(CLI::App& app, int& exit_code);
/// The map of a study on a server: format "table", "csv" or "json", to out ("-" = stdout);
/// view "amplitude" or "mean_force" for the table.
int remote_map(const std::string& server, const std::string& id, const std::string& format,
               const std::string& out, const std::string& view);

}  // namespace stickslip::client
