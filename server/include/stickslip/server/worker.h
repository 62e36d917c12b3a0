#pragma once
// The study worker: the job worker (job_worker.h) for jobs of kind "study", whose runner is
// studies::run_study (OpenMP inside; it computes only the missing runs, so an interrupted study
// resumes where it stopped).
//
// - Cancel is deferred: the study's cancel flag (RunnerOptions::cancel) stops new runs, the runs
//   that finish are committed, and run_study marks the study cancelled (the API answers 202).
// - Shutdown: the stop flag (RunnerOptions::stop) does the same but leaves the study queued, so
//   the next start resumes it.
// - With a launcher (WorkerOptions::execution, `stickslipd --launcher`), each study runs as one
//   MPI job whose rank 0 streams the runs back (studies/launcher.h); this process still commits
//   them, so progress, cancel and shutdown behave as above. A job that loses a rank is started
//   again for the missing runs up to execution.retries times, then the study is failed with
//   the launcher's message.
// - A study whose stored spec does not parse (e.g. a limit was lowered since it was queued) is
//   marked failed with the errors. A store fault (run_study's RunSummary::store_fault) leaves
//   the study queued with the error and pauses the worker (job_worker.h).

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "stickslip/server/job_worker.h"
#include "stickslip/studies/runner.h"
#include "stickslip/studies/spec.h"

namespace stickslip::server {

/// Signature of studies::run_study (injected so the worker can be tested with a fake runner).
using RunStudyFn = std::function<studies::RunSummary(
    const std::filesystem::path&, const std::string&, const studies::StudySpec&,
    const studies::RunnerOptions&)>;

struct WorkerOptions {
  int concurrency = 1;  ///< studies run at once
  int threads = 0;      ///< OpenMP threads per study; 0 = OpenMP's default
  studies::Limits limits;
  std::chrono::milliseconds poll{1000};  ///< how often the store is scanned without notify()
  /// Nice increment (Linux, per thread, 0..19, added to the process's nice value) of the worker
  /// threads and so of the OpenMP threads they start (new threads inherit it). 0: unchanged.
  /// Compare ServerOptions::io_nice: whichever of the two is lower gets the CPU first when both
  /// want it (docs/server.md, Load).
  int nice = 0;
  store::WriterOptions writer;
  /// Where studies are computed: OpenMP here (default) or one MPI job each (a launcher).
  studies::Execution execution;

  /// True if every field holds. Otherwise appends one message per broken constraint, naming the
  /// field and the value, to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// The "run this job" step of a study: parses the stored spec and calls run (run_study).
RunJobFn study_runner(RunStudyFn run, const WorkerOptions& options);

class Worker final : public JobWorker {
 public:
  Worker(std::filesystem::path db, WorkerOptions options, RunStudyFn run,
         std::shared_ptr<Health> health = nullptr);
};

}  // namespace stickslip::server
