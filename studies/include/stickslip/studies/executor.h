#pragma once
// Where the runner computes a study's missing runs (docs/scale.md). run_study (runner.h) stays
// the one writer of the store in every case: an Executor only computes and hands the records
// back, so the store's single-writer rule (docs/store.md, "One writer") holds whatever the
// backend. Three backends:
//  - local_executor(): OpenMP threads in this process (the default);
//  - the MPI master (stickslip/mpi/session.h): chunks of jobs to the worker ranks of the MPI job
//    this process is rank 0 of (`mpirun -np N stickslip study run ...`);
//  - launcher_executor() (launcher.h): one MPI job per study, started with a command prefix
//    (`mpirun -np 8 --hostfile hosts`, `srun`), whose rank 0 streams the records back to this
//    process (`stickslipd --launcher`, `stickslip study run --launcher`).
// Every backend computes each run with compute_job (compute.h), so the stored results are
// bitwise identical whatever the backend, rank count or thread count.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "stickslip/measured/measured.h"
#include "stickslip/store/store.h"
#include "stickslip/studies/spec.h"

namespace stickslip::studies {

/// What a backend computes: the missing runs of one study.
struct ComputeRequest {
  std::string study_id;
  const StudySpec* spec = nullptr;
  /// The measured data the runs are compared with (loaded by the runner), or null.
  const measured::MeasuredDataset* measured = nullptr;
  /// Where a relative spec->measured() path is resolved (for processes that load it again).
  std::filesystem::path spec_dir = ".";
  std::vector<std::size_t> pending;  ///< design indices to compute, ascending
  int threads = 0;                   ///< OpenMP threads per process; 0 = OpenMP's default
  /// A distributed backend's per-chunk deadline [s]: a chunk of runs not returned in
  /// max(chunk_deadline_s, 10 x its expected time) means its rank hung or was lost. 0: 120 s.
  double chunk_deadline_s = 0;
  /// Where a backend adds the runs it computed in the engine's batched mode (may be null).
  std::atomic<std::int64_t>* batched = nullptr;
};

/// Receives finished runs; may be called from any thread, never concurrently with itself.
using RecordSink = std::function<void(std::vector<store::RunRecord>&&)>;
/// True once no new run should start (cancel, shutdown, a failed store).
using StopFn = std::function<bool()>;

/// A backend lost work it had taken: a rank died or hung, a launched job ended early. The
/// records delivered before stay valid; running the study again computes the missing runs.
class ExecutorError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Executor {
 public:
  virtual ~Executor() = default;
  /// Computes every run of request.pending and delivers each record to sink, or stops early
  /// once stop() is true (the runs already started may still be delivered). Throws
  /// ExecutorError when the backend loses work. May be called from several threads at once.
  virtual void compute(const ComputeRequest& request, const RecordSink& sink,
                       const StopFn& stop) = 0;
  /// For logs: "OpenMP", "MPI (7 worker ranks)", "launcher 'mpirun -np 8'".
  virtual std::string describe() const = 0;
  /// What the study's error field says while this backend computes it, when losing the
  /// backend would also end the writing process, so that nobody could record why: the MPI
  /// master (a rank that dies makes the launcher end the whole job, rank 0 included). Empty:
  /// nothing (the writer records any failure itself).
  virtual std::string running_note() const { return {}; }
};

/// OpenMP threads in this process: jobs (compute.h) with schedule(dynamic).
std::shared_ptr<Executor> local_executor();

/// How run_study computes: the backend and what to do when it loses work.
struct Execution {
  std::shared_ptr<Executor> executor;  ///< null: local_executor()
  /// How often run_study starts the backend again after an ExecutorError (each time for the
  /// runs still missing) before it marks the study failed.
  int retries = 0;
  double chunk_deadline_s = 0;  ///< ComputeRequest::chunk_deadline_s
};

}  // namespace stickslip::studies
