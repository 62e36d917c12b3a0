#pragma once
// A stickslip process inside an MPI job (docs/scale.md). `mpirun -np N stickslip ...` (or
// `srun`) starts N copies; Session::start_if_launched initialises MPI in each. Rank 0 runs the
// command as usual, and the one writer of the store stays rank 0: every study it runs computes
// through executor(), the dedicated master, which hands chunks of runs to ranks 1..N-1 and
// takes their results back. Ranks 1..N-1 only serve (serve()): they never parse the command
// line's files nor open the store. Rank 0 does not compute: it must answer every request at
// once and commit, and at the scale MPI is for, one rank's share of the work is small (see
// docs/scale.md; on a node, place it beside a worker: it sleeps while it waits).
//
// Without an MPI launcher (no OMPI_COMM_WORLD_SIZE, PMIX_RANK or PMI_RANK in the environment)
// start_if_launched returns null and the program runs as a plain process: the same binary
// works with and without mpirun.
//
// Failures: a worker that misses its chunk deadline or cannot compute the study ends the study
// (ExecutorError) and breaks the session; finish() then ends the whole job with MPI_Abort, so
// a hung rank never keeps it alive. A rank that dies is ended by the launcher itself (Open MPI
// and Slurm terminate the job), rank 0 included; every run committed before stays stored.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "stickslip/studies/chunks.h"
#include "stickslip/studies/compute.h"
#include "stickslip/studies/executor.h"
#include "stickslip/studies/wire.h"

namespace stickslip::mpi {

/// True when an MPI launcher started this process (Open MPI's mpirun, or srun with PMIx/PMI2).
bool launched_by_mpi();

/// How a worker rank computes a chunk: the default is compute_job for every job on an OpenMP
/// team (schedule(dynamic)). Benchmarks pass one that returns at once (bench/mpi_ingest.cpp).
using ChunkCompute = std::function<std::vector<store::RunRecord>(
    const studies::wire::LoadedTask& task, const std::vector<studies::Job>& jobs,
    const std::string& study_id, int threads, std::atomic<std::int64_t>* batched)>;
std::vector<store::RunRecord> compute_chunk(const studies::wire::LoadedTask& task,
                                            const std::vector<studies::Job>& jobs,
                                            const std::string& study_id, int threads,
                                            std::atomic<std::int64_t>* batched);

class Session {
 public:
  /// Initialises MPI (MPI_THREAD_SERIALIZED: rank 0's master runs on the runner's compute
  /// thread) when launched by an MPI launcher; null otherwise. Throws std::runtime_error when
  /// the MPI library cannot give that thread level.
  static std::unique_ptr<Session> start_if_launched(int* argc, char*** argv);
  ~Session();  ///< finish(0) if it was not called
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  int rank() const noexcept { return rank_; }
  int size() const noexcept { return size_; }

  /// Rank 0 of a job of more than one rank: the master backend (executor.h); else null.
  std::shared_ptr<studies::Executor> executor(studies::ChunkOptions chunks = {});
  /// Ranks > 0: computes the chunks rank 0 sends until it ends the session; the exit code.
  int serve(const ChunkCompute& compute = compute_chunk);
  /// Ends the session: rank 0 releases the workers (or, when the session is broken, ends the
  /// whole job with MPI_Abort(exit_code), which does not return); then MPI_Finalize.
  int finish(int exit_code);

 private:
  Session(int rank, int size);
  int rank_ = 0, size_ = 1;
  bool finished_ = false;
  std::shared_ptr<std::atomic<bool>> broken_ = std::make_shared<std::atomic<bool>>(false);
};

}  // namespace stickslip::mpi
