#pragma once
// The study runner: computes the missing runs of a stored study across cores and stores them.
//
// Execution model (MuJoCo style: one read-only model, one workspace per run):
//  - The StudySpec is shared read-only by all threads. Each run builds its own SimConfig and
//    calls the engine, which keeps all mutable state on its own stack.
//  - A backend (executor.h; RunnerOptions::execution) computes the runs on a thread of its own:
//    OpenMP workers in this process by default (schedule(dynamic)), or the ranks of an MPI job.
//    It pushes finished RunRecords into a queue. The calling thread is the single writer: it
//    drains the queue into one RunWriter (batched transactions) and reports progress. No
//    exception leaves a parallel region: an exception of one run makes that run "invalid" with
//    the message as its error.
//  - Results depend only on (spec, design index), never on the backend, the rank or thread
//    count or the schedule: every run is computed by the same sequential code (compute.h).
//  - A backend that loses work (a rank died or hung, a launched MPI job ended early) ends the
//    attempt: what it delivered is committed, and run_study starts the backend again for the
//    missing runs up to execution.retries times, then marks the study failed with the reason.
//  - Resume: runs already stored (Store::completed_design_indices) are skipped, so a study
//    killed at any point is finished by running it again, without duplicates.
//  - Cancellation: a set cancel flag stops workers from starting new runs; runs already finished
//    are committed before run_study returns.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "stickslip/measured/measured.h"
#include "stickslip/studies/executor.h"
#include "stickslip/studies/spec.h"
#include "stickslip/store/store.h"

namespace stickslip::studies {

struct Progress {
  std::int64_t total = 0;   ///< runs of the study
  std::int64_t done = 0;    ///< runs stored, any status (including those stored before)
  std::int64_t failed = 0;  ///< stored runs with status diverged or invalid
};

struct RunnerOptions {
  int threads = 0;  ///< OpenMP threads; 0 = OpenMP's default (OMP_NUM_THREADS or all cores)
  store::WriterOptions writer;
  /// Called on the calling thread after each commit and once at the end.
  std::function<void(const Progress&)> on_progress;
  /// When set and true, no new run is started; finished runs are committed and the study is
  /// marked cancelled (a user's cancel).
  const std::atomic<bool>* cancel = nullptr;
  /// When set and true, no new run is started; finished runs are committed and the study is left
  /// in state running, so it resumes on the next run_study (a server shutting down).
  const std::atomic<bool>* stop = nullptr;
  /// Directory that a relative spec.measured() path is resolved against (the spec file's dir).
  std::filesystem::path spec_dir = ".";
  /// The backend that computes the runs (default: OpenMP in this process) and its retries.
  Execution execution;
  /// Called on the calling thread when an attempt lost work and another one starts: the
  /// attempt's number (from 1) and why it ended.
  std::function<void(int attempt, const std::string& why)> on_retry;
};

enum class RunOutcome { kCompleted, kCancelled, kStopped, kFailed };
const char* to_string(RunOutcome o) noexcept;

struct RunSummary {
  RunOutcome outcome = RunOutcome::kCompleted;
  std::string error;             ///< why the study failed (kFailed)
  /// kFailed because the store failed (busy past the retries during a shutdown, I/O error,
  /// disk full, corruption): the study is then NOT marked failed; it resumes when run again.
  store::StoreFault store_fault = store::StoreFault::kNone;
  std::int64_t total = 0;        ///< runs of the study
  std::int64_t skipped = 0;      ///< already stored before this call
  std::int64_t computed = 0;     ///< computed and stored by this call
  std::int64_t failed = 0;       ///< failed runs stored by this call
  std::int64_t batched = 0;      ///< runs computed in the engine's batched SIMD mode (rk4 only)
  double wall_s = 0.0;           ///< wall time of this call [s]
  double store_s = 0.0;          ///< of which spent in the RunWriter (adds and commits) [s]
  double compute_s = 0.0;        ///< sum over runs of their wall times [s] (CPU-seconds)
  /// A Sobol design with "until": the rule's verdict after each round, in order (the study grew
  /// after every entry but the last, which says why it stopped).
  std::vector<std::string> until;
  /// kFailed because the backend lost work (ExecutorError: a rank died or hung, a launched job
  /// ended early): every run it delivered is stored; running the study again resumes it.
  bool lost = false;
  int attempts = 1;  ///< attempts of the backend (1 + the retries used)
};

/// Computes one run of a study (no store involved): parameters, status, metrics, optional trace
/// and RMSE against the matching measured run. Never throws: a bad point gives status "invalid".
store::RunRecord compute_run(const StudySpec& spec, std::size_t design_index, const std::string& study_id,
                      const measured::MeasuredDataset* measured = nullptr);

/// A Sobol design with "until" (spec.h): after all runs of the current base size are stored, the
/// rule is evaluated on them (until_status, indices.h); while it says grow, the study is
/// extended to the next base size (Store::extend_study: the stored runs keep their indices) and
/// the new runs are computed, so the study stops by itself. Any runner can do the same with
/// until_status and extend_study: the design points are a pure function of (spec, index).
/// Runs the missing runs of study_id (which must exist in db with this spec) and sets the
/// study's state: running while working, then succeeded (all runs stored, whatever their
/// status), cancelled, running (stopped), or failed (unreadable measured data, a rejected run).
/// A busy store (another process holding the write lock) is waited for with backoff and never
/// fails the study; a persistent store fault (I/O error, disk full, corruption) ends the call
/// with kFailed and RunSummary::store_fault set, leaving the study resumable.
/// Never throws: every problem ends up in RunSummary::error and the study's error.
/// Analytic studies (ishigami, sobol_g) store their output y as stage 1's amplitude and
/// mean_force.
RunSummary run_study(const std::filesystem::path& db, const std::string& study_id,
                     const StudySpec& spec, const RunnerOptions& options = {});

/// Creates a study for spec in db, or finds the one created earlier from the same spec
/// (same name and canonical spec hash) that is not cancelled; returns it. Used by
/// `stickslip study run` to create-or-resume.
store::StudyRecord create_or_find_study(store::Store& store, const StudySpec& spec);

}  // namespace stickslip::studies
