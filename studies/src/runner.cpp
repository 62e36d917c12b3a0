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

RunSummary run_study(const std::filesystem::path& db, const std::string& study_id,
                     const StudySpec& spec, const RunnerOptions& opt) {
  const auto t_start = Clock::now();
  RunSummary sum;
  sum.total = static_cast<std::int64_t>(spec.run_count());
  const auto fail = [&](const std::string& why) {
    sum.outcome = RunOutcome::kFailed;
    sum.error = why;
    try {
      // Never create a database just to record a failure (e.g. a mistyped path).
      std::error_code ec;
      if (std::filesystem::is_regular_file(db, ec))
        store::Store::open(db).set_study_state(study_id, store::StudyState::kFailed, why);
    } catch (const std::exception&) {  // the store itself is the problem; nothing more to do
    }
    sum.wall_s = seconds_since(t_start);
    return sum;
  };

  std::vector<std::size_t> pending;
  Progress progress;
  progress.total = sum.total;
  std::optional<measured::MeasuredDataset> measured;
  {
    // The study must already be in the database: a missing file is an error, not a new store.
    std::error_code ec;
    if (!std::filesystem::is_regular_file(db, ec))
      return fail("no database at " + db.string() + " (create the study first)");
  }
  try {
    store::Store store = store::Store::open(db);
    const auto study = store.get_study(study_id);
    if (!study) return fail("unknown study '" + study_id + "' in " + db.string());
    if (study->total_runs != sum.total)
      return fail("study " + study_id + " has " + std::to_string(study->total_runs) +
                  " runs stored but its spec gives " + std::to_string(sum.total));
    if (spec.measured()) {
      std::filesystem::path path = *spec.measured();
      if (path.is_relative()) path = opt.spec_dir / path;
      try {
        measured = measured::load_measured(path);
      } catch (const measured::MeasuredError& e) {
        return fail(std::string("measured data: ") + e.what());
      }
    }
    const auto done = store.completed_design_indices(study_id);
    std::vector<bool> have(spec.run_count(), false);
    for (auto i : done)
      if (i >= 0 && static_cast<std::size_t>(i) < have.size()) have[i] = true;
    for (std::size_t i = 0; i < have.size(); ++i)
      if (!have[i]) pending.push_back(i);
    const store::RunCounts counts = store.count_runs(study_id);
    progress.done = counts.done;
    progress.failed = counts.failed;
    sum.skipped = counts.done;
    store.set_study_state(study_id, store::StudyState::kRunning);
  } catch (const std::exception& e) {
    return fail(e.what());
  }

  std::optional<store::RunWriter> writer;
  try {
    writer.emplace(store::RunWriter::open(db, opt.writer));
  } catch (const std::exception& e) {
    return fail(e.what());
  }

  // Workers -> queue -> this thread (the single writer).
  std::mutex mu;
  std::condition_variable cv;
  std::deque<store::RunRecord> queue;
  bool workers_done = false;
  std::atomic<bool> abort{false};  // set by this thread when the store fails
  const auto stop_requested = [&] {
    return abort.load(std::memory_order_relaxed) ||
           (opt.cancel != nullptr && opt.cancel->load(std::memory_order_relaxed)) ||
           (opt.stop != nullptr && opt.stop->load(std::memory_order_relaxed));
  };
  const measured::MeasuredDataset* mdata = measured ? &*measured : nullptr;

  std::atomic<std::int64_t> batched_runs{0};
  const std::vector<std::vector<std::size_t>> jobs =
      make_jobs(spec, pending, batchable(spec, mdata));
  std::thread compute([&] {
    const long n = static_cast<long>(jobs.size());
    const int threads = opt.threads > 0 ? opt.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (long k = 0; k < n; ++k) {
      if (stop_requested()) continue;
      const std::vector<std::size_t>& job = jobs[k];
      std::vector<store::RunRecord> recs;
      // No exception may leave the region: compute_run never throws, and a batch that throws
      // (it cannot for configurations make_jobs accepted) falls back to one run at a time.
      try {
        if (job.size() > 1) {
          recs = compute_batch(spec, job, study_id);
          batched_runs += static_cast<std::int64_t>(recs.size());
        }
      } catch (...) {
        recs.clear();
      }
      if (recs.empty())
        for (std::size_t i : job) {
          try {
            recs.push_back(compute_run(spec, i, study_id, mdata));
          } catch (...) {
            store::RunRecord rec;
            rec.study_id = study_id;
            rec.design_index = static_cast<std::int64_t>(i);
            rec.params_json = "{}";
            rec.param_hash = store::param_hash(rec.params_json);
            rec.status = "invalid";
            rec.error = "internal error while computing the run";
            recs.push_back(std::move(rec));
          }
        }
      {
        std::lock_guard lock(mu);
        for (store::RunRecord& rec : recs) queue.push_back(std::move(rec));
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
    std::deque<store::RunRecord> batch;
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
        for (store::RunRecord& rec : batch) {
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
  sum.batched = batched_runs.load();
  sum.store_s = store_s;
  if (!store_error.empty()) return fail("store: " + store_error);

  try {
    store::Store store = store::Store::open(db);
    const store::RunCounts counts = store.count_runs(study_id);
    progress.done = counts.done;
    progress.failed = counts.failed;
    if (counts.done >= counts.total) {
      store.set_study_state(study_id, store::StudyState::kSucceeded);
      sum.outcome = RunOutcome::kCompleted;
    } else if (opt.cancel != nullptr && opt.cancel->load()) {
      store.set_study_state(study_id, store::StudyState::kCancelled);
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
