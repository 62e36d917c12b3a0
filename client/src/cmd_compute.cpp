// `stickslip study compute`: the launched job's entry point (studies/launcher.h).
#include <unistd.h>

#include <iostream>

#include "stickslip/client/cli.h"
#include "stickslip/studies/launcher.h"

namespace stickslip::client {

void add_compute_command(CLI::App& study, int& exit_code,
                         std::shared_ptr<studies::Executor> mpi) {
  CLI::App* cmd = study.add_subcommand(
      "compute",
      "The job that --launcher starts (docs/scale.md): reads a study task on standard input, "
      "computes its runs (across the ranks when started by mpirun or srun, else with OpenMP) and "
      "writes them on standard output as frames for the process that launched it. Not for "
      "interactive use. Exit 0 done or stopped, 1 a rank was lost, 2 a bad task");
  cmd->callback([&exit_code, mpi] {
    // The frames own the real standard output; anything else printed goes to standard error.
    const int out = ::dup(1);
    if (out < 0 || ::dup2(2, 1) < 0) {
      std::cerr << "stickslip study compute: cannot set up standard output\n";
      exit_code = kFailure;
      return;
    }
    studies::Executor& executor = mpi ? *mpi : *studies::local_executor();
    exit_code = studies::serve_stream(0, out, executor);
    ::close(out);
  });
}

}  // namespace stickslip::client
