// --launcher, --retries, --chunk-deadline (execution.h).
#include "execution.h"

#include <iostream>
#include <stdexcept>

#include "stickslip/studies/launcher.h"

namespace stickslip::client {

void add_execution_options(CLI::App* cmd, ExecutionArgs& a) {
  cmd->add_option("--launcher", a.launcher,
                  "compute each study as one MPI job started with this command prefix, e.g. "
                  "\"mpirun -np 8 --hostfile hosts\" or \"srun\"; this process stays the "
                  "store's one writer (docs/scale.md)");
  cmd->add_option("--retries", a.retries,
                  "with --launcher: start the job again this many times after it lost a rank "
                  "(each time for the runs still missing)")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  cmd->add_option("--chunk-deadline", a.chunk_deadline_s,
                  "MPI: a chunk of runs not returned within max(this, 10 x its expected time) "
                  "means its rank hung or was lost [s] (0: 120 s)")
      ->check(CLI::Range(0.0, 1e7));
}

studies::Execution make_execution(const ExecutionArgs& a,
                                  const std::shared_ptr<studies::Executor>& mpi) {
  studies::Execution e;
  e.chunk_deadline_s = a.chunk_deadline_s;
  if (mpi) {
    if (!a.launcher.empty())
      throw std::invalid_argument("--launcher '" + a.launcher +
                                  "': this process already runs inside an MPI job (started by "
                                  "mpirun or srun); use one or the other");
    e.executor = mpi;
    return e;
  }
  if (a.launcher.empty()) return e;
  studies::LauncherOptions o;
  o.command = a.launcher;
  o.program = studies::sibling_program("stickslip");
  o.on_output = [](const std::string& line) { std::cerr << line << "\n"; };
  e.executor = studies::launcher_executor(o);
  e.retries = a.retries;
  return e;
}

}  // namespace stickslip::client
