#include "stickslip/engine/simulate.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "integrators.h"
#include "system.h"

namespace stickslip::engine {

const char* to_string(RunStatus s) noexcept {
  switch (s) {
    case RunStatus::kOk: return "ok";
    case RunStatus::kDiverged: return "diverged";
    case RunStatus::kInvalid: return "invalid";
  }
  return "?";
}



namespace detail {

void fail_diverged(RunContext& ctx, double t, const State& y, double ub, double h) {
  ctx.result.status = RunStatus::kDiverged;
  ctx.result.t_end = t;
  ctx.result.reason = visit_model(ctx.cfg.model, [&]<class M>(std::type_identity<M>) {
    return divergence_reason(make_model<M>(ctx.cfg), t, y.v, y.s, y.v - ub, h);
  });
}

}  // namespace detail

double force_scale(const SimConfig& cfg) {
  return visit_model(cfg.model, [&]<class M>(std::type_identity<M>) {
    return detail::force_scale(cfg, make_model<M>(cfg));
  });
}

namespace {

/// kInvalid with the configuration's errors joined; false when cfg is valid.
bool invalid(const SimConfig& cfg, SimResult* r) {
  std::vector<std::string> errors;
  if (cfg.IsValid(&errors)) return false;
  r->status = RunStatus::kInvalid;
  for (const auto& e : errors) r->reason += (r->reason.empty() ? "" : "; ") + e;
  return true;
}

/// Runs the integrator of ctx.cfg on a prepared context.
void run(detail::RunContext& ctx) {
  try {
    switch (ctx.cfg.integrator.kind) {
      case IntegratorKind::kRk4: detail::run_rk4(ctx); break;
      case IntegratorKind::kRk4Event: detail::run_rk4_event(ctx); break;
      case IntegratorKind::kAdaptive: detail::run_adaptive(ctx); break;
    }
  } catch (const InvalidParameter& e) {  // a model constructor rejected a value
    ctx.result = SimResult{};
    ctx.result.status = RunStatus::kInvalid;
    ctx.result.reason = e.what();
  }
}

SimResult simulate_saving(const SimConfig& cfg, detail::CheckpointData* save, std::size_t after) {
  SimResult r;
  if (invalid(cfg, &r)) return r;
  detail::RunContext ctx{cfg, r, detail::TraceRecorder(cfg.trace.rate, &r.trace)};
  ctx.save = save;
  ctx.save_after = after;
  if (cfg.extension.active()) {
    ctx.ext = detail::ExtRuntime(cfg.extension);
    if (cfg.extension.kind == ExtensionKind::kSensorDynamics)
      ctx.trace.set_sensor(
          detail::SensorFilter(cfg.extension.sensor_tau, cfg.extension.sensor_zeta));
  }
  if (cfg.trace.rate > 0)
    r.trace.reserve(static_cast<std::size_t>(cfg.total_duration() * cfg.trace.rate) + 2);
  run(ctx);
  return r;
}

}  // namespace

SimResult simulate(const SimConfig& cfg) { return simulate_saving(cfg, nullptr, 0); }

std::size_t SimCheckpoint::stages() const noexcept { return data_ ? data_->stages_done : 0; }

SimResult simulate(const SimConfig& cfg, std::size_t stages, SimCheckpoint* checkpoint) {
  *checkpoint = SimCheckpoint{};
  if (stages < 1 || stages >= cfg.stages.size() || cfg.integrator.kind != IntegratorKind::kAdaptive)
    return simulate(cfg);
  auto data = std::make_shared<detail::CheckpointData>();
  SimResult r = simulate_saving(cfg, data.get(), stages);
  if (r.status == RunStatus::kOk && data->stages_done == stages) checkpoint->data_ = std::move(data);
  return r;
}

SimResult simulate_from(const SimConfig& cfg, const SimCheckpoint& checkpoint) {
  SimResult r;
  if (invalid(cfg, &r)) return r;
  r.status = RunStatus::kInvalid;
  if (!checkpoint.data_) {
    r.reason = "simulate_from: the checkpoint is empty";
    return r;
  }
  const detail::CheckpointData& c = *checkpoint.data_;
  if (cfg.integrator.kind != IntegratorKind::kAdaptive) {
    r.reason = std::string("simulate_from: integrator ") + to_string(cfg.integrator.kind) +
               ": checkpoints need the adaptive integrator";
    return r;
  }
  if (!same_first_stages(cfg, c.cfg, c.stages_done)) {
    r.reason = "simulate_from: the configuration differs from the checkpoint's run in its first " +
               std::to_string(c.stages_done) + " stage(s)";
    return r;
  }
  r = c.result;
  if (cfg.trace.rate > 0)
    r.trace.reserve(static_cast<std::size_t>(cfg.total_duration() * cfg.trace.rate) + 2);
  detail::RunContext ctx{cfg, r, c.trace};
  ctx.trace.retarget(&r.trace);
  ctx.ext = c.ext;
  ctx.resume = &c;
  run(ctx);
  return r;
}

bool same_first_stages(const SimConfig& a, const SimConfig& b, std::size_t n) {
  if (a.stages.size() < n || b.stages.size() < n) return false;
  for (std::size_t i = 0; i < n; ++i)
    if (!(a.stages[i] == b.stages[i])) return false;
  return a.model == b.model && a.drive == b.drive && a.friction == b.friction &&
         a.integrator == b.integrator && a.metrics == b.metrics && a.trace == b.trace &&
         a.extension == b.extension;
}

namespace {
nlohmann::json finite_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}
}  // namespace

std::string summary_json(const SimConfig& cfg, const SimResult& r, int indent) {
  nlohmann::json j;
  j["model"] = to_string(cfg.model);
  j["integrator"] = to_string(cfg.integrator.kind);
  j["status"] = to_string(r.status);
  if (cfg.extension.active()) {
    auto& e = j["effect"];
    e["id"] = to_string(cfg.extension.kind);
    for (const auto& n : extension_parameter_names(cfg.extension.kind))
      e["params"][n] = finite_or_null(get_parameter(cfg, n));
  }
  if (!r.reason.empty()) j["reason"] = r.reason;
  j["t_end"] = finite_or_null(r.t_end);
  j["steps"] = r.steps;
  j["rejected_steps"] = r.rejected;
  j["switches"] = r.switches;
  auto& stages = j["stages"] = nlohmann::json::array();
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    const auto& m = r.stages[i];
    const Stage& st = cfg.stages[i];
    stages.push_back({{"stage", i + 1},
                      {"t_start", finite_or_null(m.t_start)},
                      {"t_end", finite_or_null(m.t_end)},
                      {"v_a", finite_or_null(st.v_a)},
                      {"f", finite_or_null(st.f)},
                      {"amplitude", finite_or_null(m.amplitude)},
                      {"amplitude_raw", finite_or_null(m.amplitude_raw)},
                      {"mean_force", finite_or_null(m.mean_force)},
                      {"mean_friction", finite_or_null(m.mean_friction)},
                      {"slip_events", m.slip_events},
                      {"mean_period", finite_or_null(m.mean_period)}});
  }
  return j.dump(indent);
}

void write_trace_csv(const std::vector<TraceSample>& trace, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot open trace file '" + path + "' for writing");
  out << "t,F_d,F_f,x,v,s\n";
  char line[256];
  for (const auto& s : trace) {
    std::snprintf(line, sizeof line, "%.9g,%.9g,%.9g,%.12g,%.9g,%.9g\n", s.t, s.F_d, s.F_f, s.x,
                  s.v, s.s);
    out << line;
  }
  if (!out) throw std::runtime_error("failed writing trace file '" + path + "'");
}

}  // namespace stickslip::engine
