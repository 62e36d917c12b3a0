// Computing runs without a store (compute.h; compute_run is declared in runner.h).
#include "stickslip/studies/compute.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <exception>
#include <optional>

#include "stickslip/engine/batch.h"
#include "stickslip/engine/simulate.h"
#include "stickslip/studies/runner.h"

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
}  // namespace

bool batchable(const StudySpec& spec, const measured::MeasuredDataset* measured) {
  return !spec.is_analytic() && measured == nullptr && spec.trace_rate() <= 0 &&
         spec.base_config().integrator.kind == engine::IntegratorKind::kRk4;
}

// Groups the pending runs into jobs: runs whose configurations can share a batch (same model,
// dt and base motion; engine/batch.h), up to the engine's lane count; every other run is a job of
// one. Groups stay open while later runs may join them (at most kOpenGroups at a time, oldest
// closed first), so a grid whose innermost axis is v_a still batches across its other axes.
// The grouping depends only on the spec and the pending set, never on threads.
std::vector<Job> make_jobs(const StudySpec& spec, const std::vector<std::size_t>& pending,
                           bool batch) {
  std::vector<Job> jobs;
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

namespace {

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


// An invalid run that says why it could not be computed.
store::RunRecord internal_error(std::size_t index, const std::string& study_id) {
  store::RunRecord rec;
  rec.study_id = study_id;
  rec.design_index = static_cast<std::int64_t>(index);
  rec.params_json = "{}";
  rec.param_hash = store::param_hash(rec.params_json);
  rec.status = "invalid";
  rec.error = "internal error while computing the run";
  return rec;
}

}  // namespace

std::vector<store::RunRecord> compute_job(const StudySpec& spec, const Job& job,
                                          const std::string& study_id,
                                          const measured::MeasuredDataset* measured,
                                          std::atomic<std::int64_t>* batched) {
  std::vector<store::RunRecord> recs;
  // No exception may leave an OpenMP region: compute_run never throws, and a batch that throws
  // (it cannot for configurations make_jobs accepted) falls back to one run at a time.
  try {
    if (job.size() > 1) {
      recs = compute_batch(spec, job, study_id);
      if (batched != nullptr) *batched += static_cast<std::int64_t>(recs.size());
    }
  } catch (...) {
    recs.clear();
  }
  if (recs.empty())
    for (std::size_t i : job) {
      try {
        recs.push_back(compute_run(spec, i, study_id, measured));
      } catch (...) {
        recs.push_back(internal_error(i, study_id));
      }
    }
  return recs;
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

}  // namespace stickslip::studies
