#pragma once
// Where a command's studies are computed (studies/executor.h): the options --launcher,
// --retries and --chunk-deadline of `study run` and `report`, and the Execution they give.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "stickslip/studies/executor.h"

namespace stickslip::client {

struct ExecutionArgs {
  std::string launcher;  ///< --launcher: one MPI job per study through this command prefix
  int retries = 0;       ///< --retries: starts of the launcher after a lost job
  double chunk_deadline_s = 0;  ///< --chunk-deadline [s]; 0: the default (120 s)
};

void add_execution_options(CLI::App* cmd, ExecutionArgs& args);

/// The Execution of a command: the MPI master when this process is rank 0 of an MPI job (mpi),
/// else the launcher when --launcher is set, else OpenMP here. Throws std::invalid_argument
/// naming the option for a bad combination (--launcher inside an MPI job).
studies::Execution make_execution(const ExecutionArgs& args,
                                  const std::shared_ptr<studies::Executor>& mpi);

}  // namespace stickslip::client
