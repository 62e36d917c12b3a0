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

// Sample rate [Hz] of the dense trace used to compare with a measured run: at least 2 kHz and
// twice the measured mean rate, so linear interpolation adds no visible error to the RMSE.
double rmse_trace_rate(const measured::MeasuredRun& m) {
  const double span = m.t.back() - m.t.front();
  const double mean_rate = span > 0 ? static_cast<double>(m.t.size() - 1) / span : 2000.0;
  return std::min(50000.0, std::max(2000.0, 2.0 * mean_rate));
}

const measured::MeasuredRun* find_match(const measured::MeasuredDataset* measured, const engine::SimConfig& cfg) {
  if (measured == nullptr) return nullptr;
  for (const measured::MeasuredRun& m : measured->runs)
    if (measured::matches_conditions(cfg, m.conditions)) return &m;
  return nullptr;
}

void fill_from_result(const engine::SimResult& res, store::RunRecord& r) {
  r.status = to_string(res.status);
  r.error = res.reason;
  r.t_end = res.t_end;
  r.steps = static_cast<std::int64_t>(res.steps);
  r.stages.clear();
  for (std::size_t s = 0; s < res.stages.size(); ++s) {
    const engine::StageMetrics& m = res.stages[s];
    store::StageMetricsRecord rec;
    rec.stage = static_cast<int>(s) + 1;
    rec.t_start = m.t_start;
    rec.t_end = m.t_end;
    rec.amplitude = m.amplitude;
    rec.amplitude_raw = m.amplitude_raw;
    rec.mean_force = m.mean_force;
    rec.mean_friction = m.mean_friction;
    rec.slip_events = m.slip_events;
    rec.mean_period = m.mean_period;
    r.stages.push_back(rec);
  }
}

// RMSE of the run against its measured run: whole trace and per stage (eq. 23 of the seed).
void add_rmse(const engine::SimConfig& cfg, const engine::SimResult& res, const measured::MeasuredRun& m, store::RunRecord& r) {
  std::vector<double> ts, fs;
  ts.reserve(res.trace.size());
  fs.reserve(res.trace.size());
  for (const engine::TraceSample& p : res.trace) {
    ts.push_back(p.t);
    fs.push_back(p.F_d);
  }
  if (res.status != engine::RunStatus::kOk) return;  // a failed run has no comparable trace
  const double whole = measured::rmse_window(m.t, m.Fd, ts, fs, 0.0, cfg.total_duration() + 1e-12);
  if (std::isfinite(whole)) r.rmse = whole;
  double t0 = 0.0;
  for (std::size_t s = 0; s < cfg.stages.size() && s < r.stages.size(); ++s) {
    const double t1 = t0 + cfg.stages[s].duration;
    const double e = measured::rmse_window(m.t, m.Fd, ts, fs, t0, s + 1 == cfg.stages.size() ? t1 + 1e-12 : t1);
    if (std::isfinite(e)) r.stages[s].rmse = e;
    t0 = t1;
  }
}

// Keeps every k-th sample so the stored trace has the rate the study asked for.
std::vector<store::TracePoint> stored_trace(const std::vector<engine::TraceSample>& trace, std::size_t every) {
  std::vector<store::TracePoint> out;
  out.reserve(trace.size() / every + 1);
  for (std::size_t i = 0; i < trace.size(); i += every) {
    const engine::TraceSample& p = trace[i];
    out.push_back({p.t, p.F_d, p.F_f, p.x, p.v, p.s});
  }
  return out;
}

// The identity columns of a run: parameters, their hash, model and va_over_vd.
void identify(const StudySpec& spec, const DesignPoint& p, store::RunRecord& r) {
  r.params_json = spec.canonical_point_json(p);
  r.param_hash = store::param_hash(r.params_json);
  if (!p.model.empty()) r.model = p.model;
  r.va_over_vd = p.value("va_over_vd");
}

// Batched mode (engine/batch.h) runs several fixed-step rk4 runs in SIMD lanes with results
// bitwise equal to simulate(), so it changes speed only. It applies when the study integrates
// with rk4 and needs no trace (no stored traces, no measured data to compare with).
bool batchable(const StudySpec& spec, const measured::MeasuredDataset* measured) {
  return !spec.is_analytic() && measured == nullptr && spec.trace_rate() <= 0 &&
         spec.base_config().integrator.kind == engine::IntegratorKind::kRk4;
}

// Groups the pending runs into jobs: runs whose configurations can share a batch (same model,
// dt and base motion; engine/batch.h), up to the engine's lane count; every other run is a job of
// one. Groups stay open while later runs may join them (at most kOpenGroups at a time, oldest
// closed first), so a grid whose innermost axis is v_a still batches across its other axes.
// The grouping depends only on the spec and the pending set, never on threads.
std::vector<std::vector<std::size_t>> make_jobs(const StudySpec& spec,
                                                const std::vector<std::size_t>& pending,
                                                bool batch) {
  std::vector<std::vector<std::size_t>> jobs;
  if (!batch) {
    jobs.reserve(pending.size());
    for (std::size_t i : pending) jobs.push_back({i});
    return jobs;
  }
  constexpr std::size_t kOpenGroups = 64;
  struct Group {
    std::vector<engine::SimConfig> cfgs;
    std::vector<std::size_t> indices;
  };
  std::deque<Group> open;
  for (std::size_t i : pending) {
    std::optional<engine::SimConfig> cfg;
    try {
      cfg = spec.config_for(spec.point(i));
    } catch (const std::exception&) {  // an invalid point: its own job, compute_run reports it
    }
    if (!cfg) {
      jobs.push_back({i});
      continue;
    }
    bool placed = false;
    for (auto it = open.begin(); it != open.end() && !placed; ++it) {
      it->cfgs.push_back(*cfg);
      if (engine::batch_compatible(it->cfgs)) {
        it->indices.push_back(i);
        placed = true;
        if (static_cast<int>(it->indices.size()) >= engine::batch_chunk_lanes(cfg->model)) {
          jobs.push_back(std::move(it->indices));
          open.erase(it);
        }
        break;
      }
      it->cfgs.pop_back();
    }
    if (placed) continue;
    if (open.size() == kOpenGroups) {
      jobs.push_back(std::move(open.front().indices));
      open.pop_front();
    }
    open.push_back(Group{{*cfg}, {i}});
  }
  for (Group& g : open) jobs.push_back(std::move(g.indices));
  return jobs;
}

// Computes a job of several batchable runs with one simulate_batch call.
std::vector<store::RunRecord> compute_batch(const StudySpec& spec, const std::vector<std::size_t>& job,
                                     const std::string& study_id) {
  const auto t0 = Clock::now();
  std::vector<store::RunRecord> out(job.size());
  std::vector<engine::SimConfig> cfgs;
  cfgs.reserve(job.size());
  for (std::size_t k = 0; k < job.size(); ++k) {
    const DesignPoint p = spec.point(job[k]);
    out[k].study_id = study_id;
    out[k].design_index = static_cast<std::int64_t>(job[k]);
    identify(spec, p, out[k]);
    cfgs.push_back(spec.config_for(p));
  }
  const std::vector<engine::SimResult> res = engine::simulate_batch(cfgs);
  const double each = seconds_since(t0) / static_cast<double>(job.size());
  for (std::size_t k = 0; k < job.size(); ++k) {
    fill_from_result(res[k], out[k]);
    out[k].wall_time_s = each;  // the lanes ran together; each gets its share
  }
  return out;
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

store::RunRecord compute_run(const StudySpec& spec, std::size_t design_index, const std::string& study_id,
                      const measured::MeasuredDataset* measured) {
  const auto t0 = Clock::now();
  store::RunRecord r;
  r.study_id = study_id;
  r.design_index = static_cast<std::int64_t>(design_index);
  try {
    const DesignPoint p = spec.point(design_index);
    identify(spec, p, r);
    if (spec.is_analytic()) {
      const double y = spec.analytic_value(p);
      store::StageMetricsRecord m;
      m.stage = 1;
      m.amplitude = m.mean_force = y;
      m.amplitude_raw = m.mean_friction = m.mean_period = std::nan("");
      r.stages.push_back(m);
    } else {
      engine::SimConfig cfg = spec.config_for(p);  // throws InvalidParameter for a bad point
      const measured::MeasuredRun* match = find_match(measured, cfg);
      const double want_rate = spec.trace_rate();
      std::size_t every = 1;
      if (match != nullptr) {
        const double need = rmse_trace_rate(*match);
        if (want_rate > 0) {
          every = static_cast<std::size_t>(std::ceil(need / want_rate));
          cfg.trace.rate = want_rate * static_cast<double>(every);
        } else {
          cfg.trace.rate = need;
        }
      }
      const engine::SimResult res = engine::simulate(cfg);  // never throws for bad input
      fill_from_result(res, r);
      if (match != nullptr) add_rmse(cfg, res, *match, r);
      if (want_rate > 0) r.trace = stored_trace(res.trace, every);
    }
  } catch (const std::exception& e) {
    r.status = "invalid";
    r.error = e.what();
    r.stages.clear();
    r.trace.clear();
    if (r.params_json.empty()) r.params_json = "{}";
    if (r.param_hash.empty()) r.param_hash = store::param_hash(r.params_json);
  }
  r.wall_time_s = seconds_since(t0);
  return r;
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

/// One call of run_study: workers compute the missing runs (compute(), its own thread with an
/// OpenMP team), the calling thread stores them (store_results()) and sets the study's state.
class StudyRun {
 public:
  StudyRun(const std::filesystem::path& db, const std::string& study_id, const StudySpec& spec,
           const RunnerOptions& opt)
      : db_(db), id_(study_id), spec_(spec), opt_(opt) {}

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
    store.set_study_state(id_, store::StudyState::kRunning);
  }

  bool stop_requested() const {
    return abort_.load(std::memory_order_relaxed) ||
           (opt_.cancel != nullptr && opt_.cancel->load(std::memory_order_relaxed)) ||
           (opt_.stop != nullptr && opt_.stop->load(std::memory_order_relaxed));
  }

  /// One job (one run, or a batch the engine computes at once); never throws.
  std::vector<store::RunRecord> compute_job(const std::vector<std::size_t>& job,
                                            const measured::MeasuredDataset* mdata) {
    std::vector<store::RunRecord> recs;
    // No exception may leave the OpenMP region: compute_run never throws, and a batch that
    // throws (it cannot for configurations make_jobs accepted) falls back to one run at a time.
    try {
      if (job.size() > 1) {
        recs = compute_batch(spec_, job, id_);
        batched_runs_ += static_cast<std::int64_t>(recs.size());
      }
    } catch (...) {
      recs.clear();
    }
    if (recs.empty())
      for (std::size_t i : job) {
        try {
          recs.push_back(compute_run(spec_, i, id_, mdata));
        } catch (...) {
          store::RunRecord rec;
          rec.study_id = id_;
          rec.design_index = static_cast<std::int64_t>(i);
          rec.params_json = "{}";
          rec.param_hash = store::param_hash(rec.params_json);
          rec.status = "invalid";
          rec.error = "internal error while computing the run";
          recs.push_back(std::move(rec));
        }
      }
    return recs;
  }

  /// The workers: every pending job, pushed into the queue as it finishes.
  void compute_all() {
    const measured::MeasuredDataset* mdata = measured_ ? &*measured_ : nullptr;
    const auto jobs = make_jobs(spec_, pending_, batchable(spec_, mdata));
    const long n = static_cast<long>(jobs.size());
    const int threads = opt_.threads > 0 ? opt_.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (long k = 0; k < n; ++k) {
      if (stop_requested()) continue;
      std::vector<store::RunRecord> recs = compute_job(jobs[static_cast<std::size_t>(k)], mdata);
      {
        std::lock_guard lock(mu_);
        for (store::RunRecord& rec : recs) queue_.push_back(std::move(rec));
      }
      cv_.notify_one();
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
        return next_round(sum_, StudyRun(db_, id_, spec_, opt_).run(), t_start_);
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
  return StudyRun(db, study_id, spec, opt).run();
}

}  // namespace stickslip::studies
