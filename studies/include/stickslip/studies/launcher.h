#pragma once
// One MPI job per study, started through a command prefix (docs/scale.md, "Launcher"):
// `stickslipd --launcher "mpirun -np 8 --hostfile hosts"`, `stickslip study run --launcher ...`,
// `stickslip report --launcher ...`. The process that calls run_study stays the store's one
// writer: it starts `<launcher> <program> study compute` (through /bin/sh, so any prefix works:
// srun, env VAR=value mpirun ...), writes the study's task on the job's standard input, and
// reads the finished runs that the job's rank 0 writes on its standard output; it commits them
// itself, so progress, cancel and the API behave as for a local study. No rank opens the store.
//
// The stream (both ends here): frames of a 4-byte little-endian length and a MessagePack
// document (wire.h). The caller sends one frame, the task; closing the job's standard input
// asks it to stop (it hands out no new chunk, returns the chunks in progress, then exits). The
// job sends {"t": "hello"}, then {"t": "runs"} frames as runs finish, {"t": "beat"} every
// second, and finally {"t": "done"} or {"t": "error", "message": ...}. Rank 0 keeps its real
// standard output for the frames and points file descriptor 1 at standard error, so nothing
// else can be mixed into the stream.
//
// Failures: a job that exits before "done" (a rank killed: mpirun ends the whole job), that
// reports an error (a rank that missed its chunk deadline), or whose rank 0 is silent for
// `silence` after its hello, ends compute() with ExecutorError naming the exit status and the
// launcher's last messages (e.g. "mpirun noticed that process rank 1 ... exited on signal 9").
// Every run received before is committed by the runner, which starts the job again for the
// missing runs (Execution::retries) or marks the study failed with that message.

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "stickslip/studies/executor.h"

namespace stickslip::studies {

struct LauncherOptions {
  /// The command prefix, e.g. "mpirun -np 8 --hostfile hosts" or "srun"; empty: the program
  /// runs directly (one process, OpenMP only).
  std::string command;
  /// The stickslip executable the job runs; it must exist at this path on every node.
  std::filesystem::path program;
  /// After a stop (cancel, shutdown), how long the job may take to return its chunks in
  /// progress before it is terminated (SIGTERM to its process group, SIGKILL 5 s later).
  std::chrono::milliseconds stop_grace{30000};
  /// Once the job said hello, how long its rank 0 may send nothing (it sends a heartbeat every
  /// second) before the job counts as lost. Before the hello there is no limit: a launcher
  /// may wait in a queue for its allocation.
  std::chrono::milliseconds silence{60000};
  /// Each line the job writes on standard error (the launcher's messages); may be empty.
  std::function<void(const std::string&)> on_output;

  /// True if every field holds; else appends one message per broken field (name and value).
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// The launcher backend. Throws std::invalid_argument when the options are not valid.
std::shared_ptr<Executor> launcher_executor(LauncherOptions options);

/// The executable `name` in the directory of this process's own executable (/proc/self/exe),
/// e.g. the `stickslip` beside `stickslipd`; else the first on PATH; else that sibling path
/// (which LauncherOptions::IsValid then reports as missing).
std::filesystem::path sibling_program(const std::string& name);

/// The job's side (`stickslip study compute`): reads the task from in_fd, computes it with
/// executor (the MPI master on rank 0 of an MPI job, else OpenMP) and writes the frames to
/// out_fd; end of input stops it. Returns the exit code: 0 done or stopped, 1 the executor
/// lost work, 2 a bad task.
int serve_stream(int in_fd, int out_fd, Executor& executor);

}  // namespace stickslip::studies
