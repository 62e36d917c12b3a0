#pragma once
// The `stickslip` command line. Subcommands register themselves on a CLI11 app; main() only
// calls run(). Exit codes: 0 success, 1 failure, 2 bad input (message on stderr).
#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "stickslip/engine/params.h"
#include "stickslip/studies/executor.h"

namespace stickslip::client {

enum ExitCode : int { kOk = 0, kFailure = 1, kBadInput = 2, kUnreachable = 3, kStudyFailed = 4 };

/// Parses argv and runs the chosen subcommand; returns the process exit code. mpi: on rank 0
/// of an MPI job, the MPI master (stickslip/mpi/session.h) that computes its studies.
int run(int argc, char** argv, std::shared_ptr<studies::Executor> mpi = nullptr);

/// --effect ID and --effect-param NAME=VALUE (repeatable) on a subcommand (simulate, synth).
void add_effect_options(CLI::App& cmd, std::string& effect, std::vector<std::string>& params);
/// Applies them to cfg: the effect id, then each parameter with set_parameter. Throws
/// InvalidParameter naming the field and the value (also for a malformed NAME=VALUE).
void apply_effect_options(const std::string& effect, const std::vector<std::string>& params,
                          engine::SimConfig& cfg);

/// A command-line flag of a friction parameter (or its alias) or a model option, derived from
/// the model registry. The flag is the name without underscores, plus the name itself when that
/// differs: k_t gives --kt and --k_t, F_C gives --FC and --F_C, DV gives --DV; an alias adds its
/// own (F_slip: --Fslip, --F_slip) to the same option.
struct ModelFlag {
  std::string names;                 ///< CLI11 option names, e.g. "--kt,--k_t"
  std::string target;                ///< the parameter or option ("k_t")
  std::string help;                  ///< description [unit] (default; the models that use it)
  std::vector<std::string> choices;  ///< an option's choices; empty for a parameter
};
/// One flag per parameter of kFrictionParameters and per option of kFrictionOptions, in order.
std::vector<ModelFlag> model_flags();
/// The flag names of a parameter or option name by the rule above ("--kt,--k_t").
std::string model_flag_names(std::string_view name);
/// The registered model ids in list order.
std::vector<std::string> model_ids();
/// --model MODEL on cmd, checked against the registered ids (the help lists them).
CLI::Option* add_model_option(CLI::App& cmd, std::string& model);

/// Subcommand registration (one function per command family).
void add_simulate_command(CLI::App& app, int& exit_code);
void add_synth_command(CLI::App& app, int& exit_code);
void add_diagnose_command(CLI::App& app, int& exit_code);
void add_validate_command(CLI::App& app, int& exit_code);  ///< `validate DIAGNOSIS MANIFEST`
void add_table_command(CLI::App& app, int& exit_code);
void add_study_command(CLI::App& app, int& exit_code, std::shared_ptr<studies::Executor> mpi);
/// `study compute`: the job a launcher starts (studies/launcher.h).
void add_compute_command(CLI::App& study, int& exit_code, std::shared_ptr<studies::Executor> mpi);
void add_store_command(CLI::App& app, int& exit_code);  ///< `store check DB`
void add_map_command(CLI::App& app, int& exit_code);  ///< `map` (local --db, or --server) and `rmse`
void add_indices_command(CLI::App& app, int& exit_code);
void add_report_command(CLI::App& app, int& exit_code, std::shared_ptr<studies::Executor> mpi);
/// submit, status, wait, runs, cancel, list: commands that talk to a stickslipd server.
void add_remote_commands(CLI::App& app, int& exit_code);
/// The map of a study on a server: format "table", "csv" or "json", to out ("-" = stdout);
/// view "amplitude" or "mean_force" for the table.
int remote_map(const std::string& server, const std::string& id, const std::string& format,
               const std::string& out, const std::string& view);

}  // namespace stickslip::client
