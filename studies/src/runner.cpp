// The study runner (see runner.h for the execution model).
#include "stickslip/studies/runner.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>

#include "stickslip/engine/batch.h"
#include "stickslip/studies/indices.h"
#include "stickslip/engine/simulate.h"

namespace stickslip::studies {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// A stored study's run count fits its spec: the design's runs, or for a Sobol design with
// "until" the runs of a base size n 2^k (or n_max) it grew to.
bool valid_extent(const StudySpec& spec, std::int64_t total) {
  const auto runs = static_cast<std::size_t>(std::max<std::int64_t>(total, 0));
  if (!spec.design().until) return runs == spec.run_count();
  return runs >= spec.run_count() && runs <= spec.max_run_count() &&
         runs % spec.design().runs_per_row() == 0;
}

// The summary of a round followed by the summary of the rounds after it.
RunSummary next_round(const RunSummary& first, RunSummary rest, Clock::time_point t_start) {
  rest.skipped = first.skipped;
  rest.computed += first.computed;
  rest.failed += first.failed;
  rest.batched += first.batched;
  rest.store_s += first.store_s;
  rest.compute_s += first.compute_s;
  rest.until.insert(rest.until.begin(), first.until.begin(), first.until.end());
  rest.wall_s = seconds_since(t_start);
  return rest;
}

}  // namespace

const char* to_string(RunOutcome o) noexcept {
  switch (o) {
    case RunOutcome::kCompleted: return "completed";
    case RunOutcome::kCancelled: return "cancelled";
    case RunOutcome::kStopped: return "stopped";
    case RunOutcome::kFailed: return "failed";
  }
  return "?";
}

store::StudyRecord create_or_find_study(store::Store& store, const StudySpec& spec) {
  const std::string canonical = spec.canonical_json();
  const std::string hash = store::param_hash(canonical);
  if (auto existing = store.find_resumable(spec.name(), hash)) return *existing;
  store::NewStudy s;
  s.name = spec.name();
  s.spec_json = canonical;
  s.spec_hash = hash;
  s.total_runs = static_cast<std::int64_t>(spec.run_count());
  return store.create_study(s).study;
}

namespace {

/// Runs op, and again while it fails because another connection holds the store's write lock
/// past the busy timeout (StoreFault::kBusy): waits 50 ms, doubling to 2 s. Gives up (rethrows)
/// only once *stop is set and patience has passed since the first failure, so a shutdown never
/// hangs on somebody else's lock, while a busy store never fails a study.
template <class Op>
auto retry_while_busy(Op&& op, const std::atomic<bool>* stop,
                      std::chrono::milliseconds patience = std::chrono::seconds(10)) {
  std::chrono::milliseconds wait{50};
  std::optional<Clock::time_point> first;
  while (true) {
    try {
      return op();
    } catch (const store::StoreError& e) {
      if (e.fault() != store::StoreFault::kBusy) throw;
      if (!first) first = Clock::now();
      if (stop != nullptr && stop->load() && Clock::now() - *first > patience) throw;
      std::this_thread::sleep_for(wait);
      wait = std::min(wait * 2, std::chrono::milliseconds(2000));
    }
  }
}

/// One attempt of run_study: the backend computes the missing runs (compute_all(), its own
/// thread), the calling thread stores them (store_results()) and sets the study's state.
/// last_attempt: whether a backend that loses work marks the study failed (else run_study
/// starts the backend again and the study stays running).
class StudyRun {
 public:
  StudyRun(const std::filesystem::path& db, const std::string& study_id, const StudySpec& spec,
           const RunnerOptions& opt, bool last_attempt = true)
      : db_(db), id_(study_id), spec_(spec), opt_(opt), last_attempt_(last_attempt) {}

  RunSummary run() {
    if (!prepare()) return sum_;
    try {
      writer_.emplace(retry_while_busy([&] { return store::RunWriter::open(db_, opt_.writer); },
                                       opt_.stop));
    } catch (const std::exception& e) {
      return fail(e);
    }
    std::thread compute([this] { compute_all(); });
    store_results();
    compute.join();
    writer_.reset();  // flushes nothing more: the buffer is empty or the store failed
    sum_.computed = committed_computed_;
    sum_.failed = committed_failed_;
    sum_.batched = batched_runs_.load();
    sum_.store_s = store_s_;
    if (store_error_) return fail("store: " + *store_error_, store_fault_);
    if (lost_ && !stop_requested()) return lost(*lost_);
    return finish();
  }

 private:
  /// Failure: the study is marked failed with why, unless the store itself failed (busy, I/O,
  /// disk full, corrupt): then it stays resumable and fault says why.
  RunSummary fail(const std::string& why, store::StoreFault fault = store::StoreFault::kNone) {
    sum_.outcome = RunOutcome::kFailed;
    sum_.error = why;
    sum_.store_fault = fault;
    std::error_code ec;
    // Never create a database just to record a failure (e.g. a mistyped path).
    if (fault == store::StoreFault::kNone && std::filesystem::is_regular_file(db_, ec)) {
      try {
        retry_while_busy([&] {
          store::Store::open(db_).set_study_state(id_, store::StudyState::kFailed, why);
        }, opt_.stop);
      } catch (const std::exception&) {  // the store itself is the problem; nothing more to do
      }
    }
    sum_.wall_s = seconds_since(t_start_);
    return sum_;
  }
  /// The backend lost work: everything it delivered is committed; the study is failed on the
  /// last attempt and stays running (for the next attempt) otherwise.
  RunSummary lost(const std::string& why) {
    std::int64_t stored = progress_.done;
    try {
      stored = store::Store::open(db_, store::Store::Mode::kReadOnly).count_runs(id_).done;
    } catch (const std::exception&) {  // the count is for the message only
    }
    sum_.lost = true;
    const std::string what = why + "; " + std::to_string(stored) + " of " +
                             std::to_string(sum_.total) + " runs are stored";
    if (last_attempt_)
      return fail(what + " (run the study again to compute the missing runs)");
    sum_.outcome = RunOutcome::kFailed;
    sum_.error = what;
    sum_.wall_s = seconds_since(t_start_);
    return sum_;
  }
  RunSummary fail(const std::exception& e, const std::string& prefix = {}) {
    const auto* se = dynamic_cast<const store::StoreError*>(&e);
    return fail(prefix + e.what(), se != nullptr ? se->fault() : store::StoreFault::kNone);
  }

  /// Checks the study, loads measured data, lists the missing runs, marks it running.
  bool prepare() {
    std::error_code ec;
    // The study must already be in the database: a missing file is an error, not a new store.
    if (!std::filesystem::is_regular_file(db_, ec)) {
      fail("no database at " + db_.string() + " (create the study first)");
      return false;
    }
    try {
      retry_while_busy([&] { prepare_in(store::Store::open(db_)); }, opt_.stop);
    } catch (const Failure& f) {
      fail(f.why);
      return false;
    } catch (const std::exception& e) {
      fail(e);
      return false;
    }
    return true;
  }

  struct Failure {
    std::string why;
  };

  void prepare_in(store::Store store) {
    const auto study = store.get_study(id_);
    if (!study) throw Failure{"unknown study '" + id_ + "' in " + db_.string()};
    if (!valid_extent(spec_, study->total_runs))
      throw Failure{"study " + id_ + " has " + std::to_string(study->total_runs) +
                    " runs stored but its spec gives " + std::to_string(spec_.run_count()) +
                    (spec_.design().until ? " growing to " + std::to_string(spec_.max_run_count())
                                          : std::string())};
    sum_.total = study->total_runs;
    progress_.total = sum_.total;
    if (spec_.measured()) {
      std::filesystem::path path = *spec_.measured();
      if (path.is_relative()) path = opt_.spec_dir / path;
      try {
        measured_ = measured::load_measured(path);
      } catch (const measured::MeasuredError& e) {
        throw Failure{std::string("measured data: ") + e.what()};
      }
    }
    const auto done = store.completed_design_indices(id_);
    std::vector<bool> have(static_cast<std::size_t>(sum_.total), false);
    for (auto i : done)
      if (i >= 0 && static_cast<std::size_t>(i) < have.size()) have[i] = true;
    pending_.clear();
    for (std::size_t i = 0; i < have.size(); ++i)
      if (!have[i]) pending_.push_back(i);
    const store::RunCounts counts = store.count_runs(id_);
    progress_.done = counts.done;
    progress_.failed = counts.failed;
    sum_.skipped = counts.done;
    const std::string note =
        opt_.execution.executor ? opt_.execution.executor->running_note() : std::string();
    store.set_study_state(id_, store::StudyState::kRunning,
                          note.empty() ? std::nullopt : std::optional<std::string>(note));
  }

  bool stop_requested() const {
    return abort_.load(std::memory_order_relaxed) ||
           (opt_.cancel != nullptr && opt_.cancel->load(std::memory_order_relaxed)) ||
           (opt_.stop != nullptr && opt_.stop->load(std::memory_order_relaxed));
  }

  /// The compute thread: the backend computes every pending run and the sink queues the records
  /// for this run's writer thread. A backend that loses work (ExecutorError) ends the round with
  /// lost_ set: what it delivered is still committed.
  void compute_all() {
    ComputeRequest req;
    req.study_id = id_;
    req.spec = &spec_;
    req.measured = measured_ ? &*measured_ : nullptr;
    std::error_code ec;
    req.spec_dir = std::filesystem::absolute(opt_.spec_dir, ec);
    if (ec) req.spec_dir = opt_.spec_dir;
    req.pending = pending_;
    req.threads = opt_.threads;
    req.chunk_deadline_s = opt_.execution.chunk_deadline_s;
    req.batched = &batched_runs_;
    const auto sink = [this](std::vector<store::RunRecord>&& recs) {
      {
        std::lock_guard lock(mu_);
        for (store::RunRecord& rec : recs) queue_.push_back(std::move(rec));
      }
      cv_.notify_one();
    };
    Executor& executor =
        opt_.execution.executor ? *opt_.execution.executor : *local_executor();
    try {
      executor.compute(req, sink, [this] { return stop_requested(); });
    } catch (const std::exception& e) {
      std::lock_guard lock(mu_);
      lost_ = std::string(e.what());
    }
    {
      std::lock_guard lock(mu_);
      workers_done_ = true;
    }
    cv_.notify_one();
  }

  void report() {
    if (opt_.on_progress) opt_.on_progress(progress_);
  }

  void on_commit() {
    committed_computed_ += buffered_computed_;
    committed_failed_ += buffered_failed_;
    progress_.done += buffered_computed_;
    progress_.failed += buffered_failed_;
    buffered_computed_ = buffered_failed_ = 0;
    report();
  }

  /// Hands a batch of finished runs to the writer. A busy store only defers the commit (the
  /// writer keeps the runs and tries again later); any other store failure stops the study.
  void add_all(std::deque<store::RunRecord>& batch) {
    for (store::RunRecord& rec : batch) {
      sum_.compute_s += rec.wall_time_s;
      const std::size_t before = writer_->buffered();
      ++buffered_computed_;
      buffered_failed_ += rec.status != "ok" ? 1 : 0;
      writer_->add(std::move(rec));
      if (writer_->buffered() <= before) on_commit();  // add() committed the batch
    }
    if (writer_->flush_if_due()) on_commit();
  }

  /// The last commit: retried while the store is busy (see retry_while_busy).
  void flush_all() {
    retry_while_busy([&] { writer_->flush(); }, opt_.stop);
    on_commit();
  }

  /// This thread: drains the workers' queue into the writer until the workers are done.
  void store_results() {
    report();
    const auto wait_slice = std::max(std::chrono::milliseconds(10), opt_.writer.max_delay / 2);
    while (true) {
      std::deque<store::RunRecord> batch;
      bool finished;
      {
        std::unique_lock lock(mu_);
        cv_.wait_for(lock, wait_slice, [&] { return !queue_.empty() || workers_done_; });
        batch.swap(queue_);
        finished = workers_done_;
      }
      if (!store_error_) {
        const auto ts = Clock::now();
        try {
          add_all(batch);
          if (finished) flush_all();
        } catch (const store::StoreError& e) {
          store_error_ = e.what();
          store_fault_ = e.fault();
          abort_ = true;
        } catch (const std::exception& e) {
          store_error_ = e.what();
          abort_ = true;
        }
        store_s_ += seconds_since(ts);
      }
      if (finished) break;
    }
  }

  /// The study's final state from what the store holds now.
  RunSummary finish() {
    try {
      const RunSummary* done = retry_while_busy([&]() -> const RunSummary* {
        store::Store store = store::Store::open(db_);
        const store::RunCounts counts = store.count_runs(id_);
        progress_.done = counts.done;
        progress_.failed = counts.failed;
        if (grown_) return &sum_;  // extended on an earlier try
        if (counts.done >= counts.total) {
          if (const auto until = until_status(store, id_)) {  // a growing Sobol design
            if (sum_.until.empty() || sum_.until.back() != until->reason)
              sum_.until.push_back(until->reason);
            if (until->grow) {
              store.extend_study(id_, static_cast<std::int64_t>(
                                          until->next_n * spec_.design().runs_per_row()));
              grown_ = true;
              return &sum_;
            }
          }
          store.set_study_state(id_, store::StudyState::kSucceeded);
          sum_.outcome = RunOutcome::kCompleted;
        } else if (opt_.cancel != nullptr && opt_.cancel->load()) {
          store.set_study_state(id_, store::StudyState::kCancelled);
          sum_.outcome = RunOutcome::kCancelled;
        } else if (opt_.stop != nullptr && opt_.stop->load()) {
          sum_.outcome = RunOutcome::kStopped;  // left running: resumes on restart
        } else {
          incomplete_ = "only " + std::to_string(counts.done) + " of " +
                        std::to_string(counts.total) + " runs are stored after the study ran";
          return nullptr;
        }
        return &sum_;
      }, opt_.stop);
      if (done == nullptr) return fail(incomplete_);
      if (grown_) {  // the next round computes the new base rows only
        report();
        return next_round(sum_, run_study(db_, id_, spec_, opt_), t_start_);
      }
    } catch (const std::exception& e) {
      return fail(e);
    }
    report();
    sum_.wall_s = seconds_since(t_start_);
    return sum_;
  }

  const std::filesystem::path& db_;
  const std::string& id_;
  const StudySpec& spec_;
  const RunnerOptions& opt_;
  const bool last_attempt_;
  const Clock::time_point t_start_ = Clock::now();
  RunSummary sum_;
  Progress progress_;
  std::vector<std::size_t> pending_;
  std::optional<measured::MeasuredDataset> measured_;
  std::optional<store::RunWriter> writer_;
  // Workers -> queue -> this thread (the single writer).
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<store::RunRecord> queue_;
  bool workers_done_ = false;
  std::atomic<bool> abort_{false};  // set by this thread when the store fails
  std::atomic<std::int64_t> batched_runs_{0};
  std::optional<std::string> store_error_;
  std::optional<std::string> lost_;  ///< why the backend lost work (ExecutorError)
  store::StoreFault store_fault_ = store::StoreFault::kNone;
  std::string incomplete_;
  bool grown_ = false;  ///< a Sobol design with "until" was extended: another round follows
  double store_s_ = 0.0;
  std::int64_t committed_computed_ = 0, committed_failed_ = 0;
  std::int64_t buffered_computed_ = 0, buffered_failed_ = 0;
};

}  // namespace

RunSummary run_study(const std::filesystem::path& db, const std::string& study_id,
                     const StudySpec& spec, const RunnerOptions& opt) {
  const Clock::time_point t_start = Clock::now();
  const int attempts = 1 + std::max(0, opt.execution.retries);
  std::optional<RunSummary> before;  // the attempts so far
  for (int attempt = 1;; ++attempt) {
    RunSummary sum = StudyRun(db, study_id, spec, opt, attempt == attempts).run();
    if (before) sum = next_round(*before, std::move(sum), t_start);
    sum.attempts = attempt;
    if (sum.outcome != RunOutcome::kFailed || !sum.lost || attempt == attempts) return sum;
    if (opt.on_retry) opt.on_retry(attempt, sum.error);
    before = std::move(sum);
  }
}

}  // namespace stickslip::studies
