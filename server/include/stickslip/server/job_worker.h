#pragma once
// One worker for every kind of job (studies, diagnoses, ...; /work/notes/jobs.md): threads of
// its own, never the HTTP threads, that take the queued jobs of one kind from the store in
// creation order and run each through the kind's RunJobFn, the one seam between the job system
// and what a job does.
//
// - The store is the queue: jobs in state queued or running (running = interrupted by a crash or
//   a shutdown) are found with the indexed claim query (Store::pending_jobs) and switched to
//   running (Store::claim_job) under the worker's mutex, which cancel() takes too: a job is never
//   run twice, and a cancel either reaches the thread that runs it or cancels it in the store.
// - Cancel (JobWorkerOptions::cancel): kDeferred (studies) sets the job's cancel flag; the
//   runner commits what it finished and ends the job cancelled (202). kImmediate (diagnoses)
//   marks it cancelled in the store at once and sets the flag; whatever result still comes is
//   discarded (Store::finish_job stores only while queued or running).
// - shutdown(grace): no job is claimed any more; running ones are put back to queued in the
//   store at once and their stop flag is set; the threads get `grace` to end (a runner that
//   finishes meanwhile still stores its outcome), then are detached, and shutdown returns false.
// - Store faults: a busy store (SQLITE_BUSY, another process's lock) is retried with backoff by
//   the store operations themselves and never fails a job. A persistent fault (I/O error, disk
//   full, corruption) puts the job back to queued with the error, marks the Health degraded
//   (/healthz answers 503) and pauses the worker with exponential backoff (1 s doubling to
//   backoff_max): one attempt and one log line per pause, no hot loop. The first claim that
//   writes to the store again clears it.

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/server/health.h"
#include "stickslip/store/store.h"

namespace stickslip::server {

enum class CancelOutcome {
  kNotFound,         ///< no such job (of this kind)
  kCancelled,        ///< it was waiting, or (kImmediate) running: now cancelled
  kRequested,        ///< (kDeferred) a thread runs it: no new work starts; cancelled shortly
  kAlreadyFinished,  ///< succeeded, failed or cancelled before: unchanged
};

/// What the HTTP handlers need from a worker: a wake-up when a job is queued, and cancellation
/// that is consistent with the worker picking jobs up.
class JobScheduler {
 public:
  virtual ~JobScheduler() = default;
  /// A job was queued: look at the store now rather than at the next poll.
  virtual void notify() = 0;
  /// Cancels a job of this kind; store is the calling thread's own connection.
  virtual CancelOutcome cancel(store::Store& store, const std::string& id) = 0;
  /// The live progress of a job it runs now (a diagnosis' phase and evaluations), if it keeps
  /// one; shown by GET on the job. Thread-safe.
  virtual std::optional<nlohmann::json> progress(const std::string& /*id*/) const { return std::nullopt; }
};

/// Cancellation without a worker: a queued or running job of kind becomes cancelled; a
/// finished one is left unchanged.
CancelOutcome cancel_unclaimed(store::Store& store, const std::string& kind,
                               const std::string& id);

/// How one run of a job ended, as its runner reports it.
struct JobOutcome {
  enum class Kind {
    kSucceeded,   ///< stored as succeeded, with result (if any)
    kFailed,      ///< stored as failed, with error
    kCancelled,   ///< the user's cancel: stored as cancelled
    kStopped,     ///< shutdown: put back to queued (the next start resumes or reruns it)
    kRecorded,    ///< the runner stored the job's final state itself (run_study does)
    kStoreFault,  ///< the store failed persistently: queued again with error; the worker pauses
  };
  Kind kind = Kind::kSucceeded;
  std::optional<std::string> result;  ///< JSON object (kSucceeded)
  std::optional<std::string> error;   ///< kFailed, kStoreFault
};
const char* to_string(JobOutcome::Kind kind) noexcept;

/// What a runner gets for one claimed job.
struct JobContext {
  const store::JobRecord& job;        ///< state running; request_json loaded
  const std::filesystem::path& db;    ///< the store (open more connections as needed)
  store::Store& store;                ///< the worker thread's connection
  const std::atomic<bool>& cancel;    ///< set by the user's cancel
  const std::atomic<bool>& stop;      ///< set by shutdown
  bool should_stop() const noexcept { return cancel.load() || stop.load(); }
};

/// The seam: runs one claimed job to its end and says how it ended. Runs on a worker thread.
/// Exceptions are caught by the worker: a StoreError with a persistent fault counts as
/// kStoreFault, any other exception as kFailed with its message (or, once a stop or cancel was
/// requested, as kStopped / kCancelled).
using RunJobFn = std::function<JobOutcome(JobContext&)>;

enum class CancelMode { kDeferred, kImmediate };

struct JobWorkerOptions {
  std::string kind;                       ///< "study", "diagnosis", ...
  int concurrency = 1;                    ///< jobs run at once
  std::chrono::milliseconds poll{1000};   ///< store scan period without notify()
  /// Nice increment (Linux, per thread, 0..19) of the worker threads and of the threads they
  /// start (OpenMP teams inherit it). 0: unchanged.
  int nice = 0;
  CancelMode cancel = CancelMode::kDeferred;
  std::chrono::milliseconds backoff_first{1000};  ///< first pause after a store fault
  std::chrono::milliseconds backoff_max{60000};   ///< the pause doubles up to this

  /// True if every field holds. Otherwise appends one message per broken constraint, naming the
  /// field and the value, to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// The options of a worker that runs one job of `kind` at a time and cancels it at once (the
/// diagnosis and validation workers).
JobWorkerOptions one_at_a_time(std::string kind, std::chrono::milliseconds poll, int nice);

class JobWorker : public JobScheduler {
 public:
  /// health may be null (then faults are only logged).
  JobWorker(std::filesystem::path db, JobWorkerOptions options, RunJobFn run,
            std::shared_ptr<Health> health = nullptr);
  ~JobWorker() override;  ///< shutdown() with an unlimited grace
  JobWorker(const JobWorker&) = delete;
  JobWorker& operator=(const JobWorker&) = delete;

  /// Starts the worker threads (once).
  void start();
  /// See the header comment. Idempotent. true: every thread ended; false: some were detached.
  bool shutdown(std::chrono::milliseconds grace = std::chrono::milliseconds::max());

  void notify() override;
  CancelOutcome cancel(store::Store& store, const std::string& id) override;

  /// Ids of the jobs being run now.
  std::vector<std::string> running() const;
  /// Jobs finished by this worker (any outcome) since start.
  std::size_t finished() const noexcept;
  const JobWorkerOptions& options() const noexcept;

  struct Shared;

 private:
  std::shared_ptr<Shared> shared_;
  std::vector<std::thread> threads_;
};

}  // namespace stickslip::server
