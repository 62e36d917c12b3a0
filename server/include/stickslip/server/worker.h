#pragma once
// The study worker: threads of their own (never the HTTP I/O threads) that take queued studies
// from the store in creation order and run them with studies::run_study (OpenMP inside).
//
// - concurrency studies run at once (default 1), each with its own cancel flag. A worker thread
//   claims a study under a mutex, after re-reading its state, so a study is never run twice and
//   a cancel either reaches the worker that claimed it or cancels it in the store.
// - The store is the queue: studies in state queued or running (running = interrupted by a
//   crash or a shutdown) are picked up in id order (= creation order), so after a restart every
//   unfinished study resumes by itself; run_study computes only the missing runs.
// - shutdown(): no study is claimed any more and the stop flag (RunnerOptions::stop) of every
//   running study is set: run_study starts no new run, commits the runs that finish, and returns
//   kStopped. The study is then put back to queued (not cancelled), so the next start resumes
//   it. Blocks until done. A user's cancel sets RunnerOptions::cancel instead (-> cancelled).
// - A study whose stored spec does not parse (e.g. a limit was lowered since it was queued) is
//   marked failed with the errors.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "stickslip/server/scheduler.h"
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

  bool IsValid(std::string* why) const;
};

class Worker final : public Scheduler {
 public:
  Worker(std::filesystem::path db, WorkerOptions options, RunStudyFn run);
  ~Worker() override;  ///< shutdown()
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  /// Starts the worker threads (once).
  void start();
  /// See the header comment. Idempotent; blocks until every worker thread has finished.
  void shutdown();

  void notify() override;
  CancelOutcome cancel(store::Store& store, const std::string& id) override;

  /// Ids of the studies being run now.
  std::vector<std::string> running() const;
  /// Studies finished by this worker (any outcome) since start.
  std::size_t finished() const noexcept { return finished_.load(); }

 private:
  struct Claim {
    std::atomic<bool> cancel{false};  // a user's cancel
    std::atomic<bool> stop{false};    // shutdown
  };
  void loop();
  /// Under mu_: the next unclaimed queued/running study, claimed; empty when none.
  std::string claim_next(store::Store& store, std::shared_ptr<Claim>* claim);
  void run_one(store::Store& store, const std::string& id, const std::shared_ptr<Claim>& claim);

  std::filesystem::path db_;
  WorkerOptions options_;
  RunStudyFn run_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::uint64_t notifications_ = 0;
  std::map<std::string, std::shared_ptr<Claim>> claims_;
  std::vector<std::thread> threads_;
  std::atomic<std::size_t> finished_{0};
};

}  // namespace stickslip::server
