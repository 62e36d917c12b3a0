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

#include "stickslip/engine/simulate.h"

namespace stickslip::studies {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Sample rate [Hz] of the dense trace used to compare with a measured run: at least 2 kHz and
// twice the measured mean rate, so linear interpolation adds no visible error to the RMSE.
double rmse_trace_rate(const MeasuredRun& m) {
  const double span = m.t.back() - m.t.front();
  const double mean_rate = span > 0 ? static_cast<double>(m.t.size() - 1) / span : 2000.0;
  return std::min(50000.0, std::max(2000.0, 2.0 * mean_rate));
}

const MeasuredRun* find_match(const MeasuredDataset* measured, const SimConfig& cfg) {
  if (measured == nullptr) return nullptr;
  for (const MeasuredRun& m : measured->runs)
    if (matches_conditions(cfg, m.conditions)) return &m;
  return nullptr;
}

void fill_from_result(const SimResult& res, RunRecord& r) {
  r.status = to_string(res.status);
  r.error = res.reason;
  r.t_end = res.t_end;
  r.steps = static_cast<std::int64_t>(res.steps);
  r.stages.clear();
  for (std::size_t s = 0; s < res.stages.size(); ++s) {
    const StageMetrics& m = res.stages[s];
    StageMetricsRecord rec;
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
void add_rmse(const SimConfig& cfg, const SimResult& res, const MeasuredRun& m, RunRecord& r) {
  std::vector<double> ts, fs;
  ts.reserve(res.trace.size());
  fs.reserve(res.trace.size());
  for (const TraceSample& p : res.trace) {
    ts.push_back(p.t);
    fs.push_back(p.F_d);
  }
  if (res.status != RunStatus::kOk) return;  // a failed run has no comparable trace
  const double whole = rmse_window(m.t, m.Fd, ts, fs, 0.0, cfg.total_duration() + 1e-12);
  if (std::isfinite(whole)) r.rmse = whole;
  double t0 = 0.0;
  for (std::size_t s = 0; s < cfg.stages.size() && s < r.stages.size(); ++s) {
    const double t1 = t0 + cfg.stages[s].duration;
    const double e = rmse_window(m.t, m.Fd, ts, fs, t0, s + 1 == cfg.stages.size() ? t1 + 1e-12 : t1);
    if (std::isfinite(e)) r.stages[s].rmse = e;
    t0 = t1;
  }
}

// Keeps every k-th sample so the stored trace has the rate the study asked for.
std::vector<TracePoint> stored_trace(const std::vector<TraceSample>& trace, std::size_t every) {
  std::vector<TracePoint> out;
  out.reserve(trace.size() / every + 1);
  for (std::size_t i = 0; i < trace.size(); i += every) {
    const TraceSample& p = trace[i];
    out.push_back({p.t, p.F_d, p.F_f, p.x, p.v, p.s});
  }
  return out;
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

RunRecord compute_run(const StudySpec& spec, std::size_t design_index, const std::string& study_id,
                      const MeasuredDataset* measured) {
  const auto t0 = Clock::now();
  RunRecord r;
  r.study_id = study_id;
  r.design_index = static_cast<std::int64_t>(design_index);
  try {
    const DesignPoint p = spec.point(design_index);
    r.params_json = spec.canonical_point_json(p);
    r.param_hash = param_hash(r.params_json);
    if (!p.model.empty()) r.model = p.model;
    r.va_over_vd = p.value("va_over_vd");
    if (spec.is_analytic()) {
      const double y = spec.analytic_value(p);
      StageMetricsRecord m;
      m.stage = 1;
      m.amplitude = m.mean_force = y;
      m.amplitude_raw = m.mean_friction = m.mean_period = std::nan("");
      r.stages.push_back(m);
    } else {
      SimConfig cfg = spec.config_for(p);  // throws InvalidParameter for a bad point
      const MeasuredRun* match = find_match(measured, cfg);
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
      const SimResult res = simulate(cfg);  // never throws for bad input
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
    if (r.param_hash.empty()) r.param_hash = param_hash(r.params_json);
  }
  r.wall_time_s = seconds_since(t0);
  return r;
}

StudyRecord create_or_find_study(Store& store, const StudySpec& spec) {
  const std::string canonical = spec.canonical_json();
  const std::string hash = param_hash(canonical);
  if (auto existing = store.find_resumable(spec.name(), hash)) return *existing;
  NewStudy s;
  s.name = spec.name();
  s.spec_json = canonical;
  s.spec_hash = hash;
  s.total_runs = static_cast<std::int64_t>(spec.run_count());
  return store.create_study(s).study;
}

RunSummary run_study(const std::filesystem::path& db, const std::string& study_id,
                     const StudySpec& spec, const RunnerOptions& opt) {
  const auto t_start = Clock::now();
  RunSummary sum;
  sum.total = static_cast<std::int64_t>(spec.run_count());
  const auto fail = [&](const std::string& why) {
    sum.outcome = RunOutcome::kFailed;
    sum.error = why;
    try {
      Store::open(db).set_study_state(study_id, StudyState::kFailed, why);
    } catch (const std::exception&) {  // the store itself is the problem; nothing more to do
    }
    sum.wall_s = seconds_since(t_start);
    return sum;
  };

  std::vector<std::size_t> pending;
  Progress progress;
  progress.total = sum.total;
  std::optional<MeasuredDataset> measured;
  try {
    Store store = Store::open(db);
    const auto study = store.get_study(study_id);
    if (!study) return fail("unknown study '" + study_id + "' in " + db.string());
    if (study->total_runs != sum.total)
      return fail("study " + study_id + " has " + std::to_string(study->total_runs) +
                  " runs stored but its spec gives " + std::to_string(sum.total));
    if (spec.measured()) {
      std::filesystem::path path = *spec.measured();
      if (path.is_relative()) path = opt.spec_dir / path;
      try {
        measured = load_measured(path);
      } catch (const MeasuredError& e) {
        return fail(std::string("measured data: ") + e.what());
      }
    }
    const auto done = store.completed_design_indices(study_id);
    std::vector<bool> have(spec.run_count(), false);
    for (auto i : done)
      if (i >= 0 && static_cast<std::size_t>(i) < have.size()) have[i] = true;
    for (std::size_t i = 0; i < have.size(); ++i)
      if (!have[i]) pending.push_back(i);
    const RunCounts counts = store.count_runs(study_id);
    progress.done = counts.done;
    progress.failed = counts.failed;
    sum.skipped = counts.done;
    store.set_study_state(study_id, StudyState::kRunning);
  } catch (const std::exception& e) {
    return fail(e.what());
  }

  std::optional<RunWriter> writer;
  try {
    writer.emplace(RunWriter::open(db, opt.writer));
  } catch (const std::exception& e) {
    return fail(e.what());
  }

  // Workers -> queue -> this thread (the single writer).
  std::mutex mu;
  std::condition_variable cv;
  std::deque<RunRecord> queue;
  bool workers_done = false;
  std::atomic<bool> abort{false};  // set by this thread when the store fails
  const auto stop_requested = [&] {
    return abort.load(std::memory_order_relaxed) ||
           (opt.cancel != nullptr && opt.cancel->load(std::memory_order_relaxed)) ||
           (opt.stop != nullptr && opt.stop->load(std::memory_order_relaxed));
  };
  const MeasuredDataset* mdata = measured ? &*measured : nullptr;

  std::thread compute([&] {
    const long n = static_cast<long>(pending.size());
    const int threads = opt.threads > 0 ? opt.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (long k = 0; k < n; ++k) {
      if (stop_requested()) continue;
      // compute_run never throws; the guard keeps even an allocation failure inside the region.
      RunRecord rec;
      try {
        rec = compute_run(spec, pending[k], study_id, mdata);
      } catch (...) {
        rec.study_id = study_id;
        rec.design_index = static_cast<std::int64_t>(pending[k]);
        rec.params_json = "{}";
        rec.param_hash = param_hash(rec.params_json);
        rec.status = "invalid";
        rec.error = "internal error while computing the run";
      }
      {
        std::lock_guard lock(mu);
        queue.push_back(std::move(rec));
      }
      cv.notify_one();
    }
    {
      std::lock_guard lock(mu);
      workers_done = true;
    }
    cv.notify_one();
  });

  std::string store_error;
  double store_s = 0.0;
  const auto report = [&] {
    if (opt.on_progress) opt.on_progress(progress);
  };
  report();
  std::int64_t committed_computed = 0, committed_failed = 0;
  std::int64_t buffered_computed = 0, buffered_failed = 0;
  const auto on_commit = [&] {
    committed_computed += buffered_computed;
    committed_failed += buffered_failed;
    progress.done += buffered_computed;
    progress.failed += buffered_failed;
    buffered_computed = buffered_failed = 0;
    report();
  };
  const auto wait_slice = std::max(std::chrono::milliseconds(10), opt.writer.max_delay / 2);
  while (true) {
    std::deque<RunRecord> batch;
    bool finished;
    {
      std::unique_lock lock(mu);
      cv.wait_for(lock, wait_slice, [&] { return !queue.empty() || workers_done; });
      batch.swap(queue);
      finished = workers_done;
    }
    if (store_error.empty()) {
      const auto ts = Clock::now();
      try {
        for (RunRecord& rec : batch) {
          const bool failed = rec.status != "ok";
          sum.compute_s += rec.wall_time_s;
          const std::size_t before = writer->buffered();
          ++buffered_computed;
          buffered_failed += failed ? 1 : 0;
          writer->add(std::move(rec));
          if (writer->buffered() <= before) on_commit();  // add() committed the batch
        }
        if (writer->flush_if_due()) on_commit();
        if (finished) {
          writer->flush();
          on_commit();
        }
      } catch (const std::exception& e) {
        store_error = e.what();
        abort = true;
      }
      store_s += seconds_since(ts);
    }
    if (finished) break;
  }
  compute.join();
  writer.reset();  // flushes nothing more: the buffer is empty or the store failed

  sum.computed = committed_computed;
  sum.failed = committed_failed;
  sum.store_s = store_s;
  if (!store_error.empty()) return fail("store: " + store_error);

  try {
    Store store = Store::open(db);
    const RunCounts counts = store.count_runs(study_id);
    progress.done = counts.done;
    progress.failed = counts.failed;
    if (counts.done >= counts.total) {
      store.set_study_state(study_id, StudyState::kSucceeded);
      sum.outcome = RunOutcome::kCompleted;
    } else if (opt.cancel != nullptr && opt.cancel->load()) {
      store.set_study_state(study_id, StudyState::kCancelled);
      sum.outcome = RunOutcome::kCancelled;
    } else if (opt.stop != nullptr && opt.stop->load()) {
      sum.outcome = RunOutcome::kStopped;  // left running: resumes on restart
    } else {
      return fail("only " + std::to_string(counts.done) + " of " + std::to_string(counts.total) +
                  " runs are stored after the study ran");
    }
  } catch (const std::exception& e) {
    return fail(e.what());
  }
  report();
  sum.wall_s = seconds_since(t_start);
  return sum;
}

}  // namespace stickslip::studies
