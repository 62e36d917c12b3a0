#include "stickslip/engine/params.h"

#include <cmath>
#include <cstdio>
#include <functional>
#include <sstream>

namespace stickslip::engine {
namespace {

std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// Domain of a scalar parameter. Every one must be finite.
enum class Domain { kPositive, kNonNegative, kAny, kFraction };

struct Field {
  const char* name;
  Domain domain;
  std::function<double&(SimConfig&)> ref;
  const char* unit;
};

const std::vector<Field>& fields() {
  static const std::vector<Field> kFields = {
      {"m", Domain::kPositive, [](SimConfig& c) -> double& { return c.drive.m; }, "kg"},
      {"k_d", Domain::kPositive, [](SimConfig& c) -> double& { return c.drive.k_d; }, "N/m"},
      {"v_d", Domain::kPositive, [](SimConfig& c) -> double& { return c.drive.v_d; }, "m/s"},
      {"F_z", Domain::kPositive, [](SimConfig& c) -> double& { return c.drive.F_z; }, "N"},
      {"k_t", Domain::kPositive, [](SimConfig& c) -> double& { return c.friction.k_t; }, "N/m"},
      {"kappa", Domain::kPositive, [](SimConfig& c) -> double& { return c.friction.kappa; }, "-"},
      {"F_C", Domain::kPositive, [](SimConfig& c) -> double& { return c.friction.F_C; }, "N"},
      {"F_slip", Domain::kPositive, [](SimConfig& c) -> double& { return c.friction.F_C; }, "N"},
      {"F_S", Domain::kPositive, [](SimConfig& c) -> double& { return c.friction.F_S; }, "N"},
      {"DV", Domain::kPositive, [](SimConfig& c) -> double& { return c.friction.DV; }, "m/s"},
      {"beta", Domain::kNonNegative, [](SimConfig& c) -> double& { return c.friction.beta; },
       "N s/m"},
      {"s0", Domain::kPositive, [](SimConfig& c) -> double& { return c.friction.s0; }, "m"},
      {"alpha", Domain::kNonNegative, [](SimConfig& c) -> double& { return c.friction.alpha; },
       "-"},
      {"h_t", Domain::kNonNegative, [](SimConfig& c) -> double& { return c.friction.h_t; },
       "N s/m"},
      {"h_v", Domain::kNonNegative, [](SimConfig& c) -> double& { return c.friction.h_v; },
       "N s/m"},
      {"v_s", Domain::kPositive, [](SimConfig& c) -> double& { return c.friction.v_s; }, "m/s"},
      {"dt", Domain::kPositive, [](SimConfig& c) -> double& { return c.integrator.dt; }, "s"},
      {"rtol", Domain::kPositive, [](SimConfig& c) -> double& { return c.integrator.rtol; }, "-"},
      {"atol", Domain::kPositive, [](SimConfig& c) -> double& { return c.integrator.atol; }, "N"},
      {"dt_max", Domain::kPositive, [](SimConfig& c) -> double& { return c.integrator.dt_max; },
       "s"},
      {"settle_fraction", Domain::kFraction,
       [](SimConfig& c) -> double& { return c.metrics.settle_fraction; }, "-"},
      {"cycle_threshold", Domain::kPositive,
       [](SimConfig& c) -> double& { return c.metrics.cycle_threshold; }, "N"},
  };
  return kFields;
}

void check_domain(std::string_view name, double v, Domain d) {
  if (!std::isfinite(v)) throw InvalidParameter(std::string(name), v, "must be a finite number");
  switch (d) {
    case Domain::kPositive:
      if (!(v > 0)) throw InvalidParameter(std::string(name), v, "must be > 0");
      break;
    case Domain::kNonNegative:
      if (!(v >= 0)) throw InvalidParameter(std::string(name), v, "must be >= 0");
      break;
    case Domain::kFraction:
      if (!(v >= 0 && v < 1)) throw InvalidParameter(std::string(name), v, "must be in [0, 1)");
      break;
    case Domain::kAny:
      break;
  }
}

// "stage<i>.<field>" -> (index from 0, field). Returns false when name has another shape.
bool parse_stage_name(std::string_view name, std::size_t* index, std::string_view* field) {
  if (name.substr(0, 5) != "stage") return false;
  const auto dot = name.find('.');
  if (dot == std::string_view::npos || dot == 5) return false;
  std::size_t i = 0;
  for (std::size_t k = 5; k < dot; ++k) {
    if (name[k] < '0' || name[k] > '9') return false;
    i = i * 10 + static_cast<std::size_t>(name[k] - '0');
    if (i > 1000000) return false;
  }
  if (i == 0) return false;
  *index = i - 1;
  *field = name.substr(dot + 1);
  return true;
}

void require_stage(const SimConfig& c, std::string_view name, std::size_t i, double v) {
  if (i >= c.stages.size())
    throw InvalidParameter(std::string(name), v,
                           "refers to stage " + std::to_string(i + 1) + " but the run has " +
                               std::to_string(c.stages.size()) + " stage(s)");
}

}  // namespace

InvalidParameter::InvalidParameter(std::string field, double value, const std::string& why)
    : std::invalid_argument(field + " = " + fmt(value) + ": " + why), field_(std::move(field)) {}
InvalidParameter::InvalidParameter(std::string field, const std::string& value,
                                   const std::string& why)
    : std::invalid_argument(field + " = \"" + value + "\": " + why), field_(std::move(field)) {}

const char* to_string(ModelKind m) noexcept {
  switch (m) {
    case ModelKind::kDahl: return "dahl";
    case ModelKind::kKarnopp: return "karnopp";
    case ModelKind::kResetIntegrator: return "reset_integrator";
    case ModelKind::kLuGre: return "lugre";
  }
  return "?";
}

ModelKind model_from_string(std::string_view name) {
  if (name == "dahl") return ModelKind::kDahl;
  if (name == "karnopp") return ModelKind::kKarnopp;
  if (name == "reset_integrator") return ModelKind::kResetIntegrator;
  if (name == "lugre") return ModelKind::kLuGre;
  throw InvalidParameter("model", std::string(name),
                         "unknown model; expected one of dahl, karnopp, reset_integrator, lugre");
}

const char* to_string(IntegratorKind k) noexcept {
  switch (k) {
    case IntegratorKind::kRk4: return "rk4";
    case IntegratorKind::kRk4Event: return "rk4_event";
    case IntegratorKind::kAdaptive: return "adaptive";
  }
  return "?";
}

IntegratorKind integrator_from_string(std::string_view name) {
  if (name == "rk4") return IntegratorKind::kRk4;
  if (name == "rk4_event") return IntegratorKind::kRk4Event;
  if (name == "adaptive") return IntegratorKind::kAdaptive;
  throw InvalidParameter("integrator", std::string(name),
                         "unknown integrator; expected one of rk4, rk4_event, adaptive");
}

SimConfig SimConfig::seed(ModelKind model, double v_a) {
  SimConfig c;
  c.model = model;
  c.stages = {Stage{10.0, 0.0, 1500.0}, Stage{10.0, v_a, 1500.0}};
  return c;
}

double SimConfig::total_duration() const noexcept {
  double t = 0;
  for (const auto& s : stages) t += s.duration;
  return t;
}

bool SimConfig::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& msg) {
    ok = false;
    if (errors) errors->push_back(msg);
  };
  SimConfig copy = *this;
  for (const auto& f : fields()) {
    try {
      check_domain(f.name, f.ref(copy), f.domain);
    } catch (const InvalidParameter& e) {
      if (std::string_view(f.name) != "F_slip") fail(e.what());  // alias of F_C
    }
  }
  const auto& fr = friction;
  const bool uses_fs = model == ModelKind::kKarnopp || model == ModelKind::kLuGre;
  if (uses_fs && std::isfinite(fr.F_S) && std::isfinite(fr.F_C) && fr.F_S < fr.F_C)
    fail("F_S = " + fmt(fr.F_S) + ": must be >= F_C = " + fmt(fr.F_C));
  if (stages.empty()) fail("stages: a run needs at least one stage");
  for (std::size_t i = 0; i < stages.size(); ++i) {
    const std::string p = "stage" + std::to_string(i + 1) + ".";
    const auto& s = stages[i];
    if (!std::isfinite(s.duration) || !(s.duration > 0))
      fail(p + "duration = " + fmt(s.duration) + ": must be a finite number > 0");
    if (!std::isfinite(s.v_a) || !(s.v_a >= 0))
      fail(p + "v_a = " + fmt(s.v_a) + ": must be a finite number >= 0");
    if (!std::isfinite(s.f) || !(s.f > 0))
      fail(p + "f = " + fmt(s.f) + ": must be a finite number > 0");
  }
  const auto& in = integrator;
  if (std::isfinite(in.dt) && in.dt > 0 && std::isfinite(total_duration()) &&
      total_duration() / in.dt > in.max_steps && in.kind != IntegratorKind::kAdaptive)
    fail("dt = " + fmt(in.dt) + ": needs more than max_steps = " + fmt(in.max_steps) + " steps");
  if (!std::isfinite(in.atol) || !(in.atol > 0))
    fail("atol = " + fmt(in.atol) + ": must be a finite number > 0");
  // x_max: sliding distance of the run, about v_d times its duration [m].
  if (!extension.IsValid(errors, drive.v_d * total_duration())) ok = false;
  if (std::isfinite(trace.rate) ? trace.rate < 0 : true)
    fail("trace_rate = " + fmt(trace.rate) + ": must be a finite number >= 0");
  return ok;
}

void SimConfig::Validate() const {
  std::vector<std::string> errors;
  if (!IsValid(&errors)) {
    std::string all;
    for (const auto& e : errors) all += (all.empty() ? "" : "; ") + e;
    throw std::invalid_argument(all);
  }
}

void set_parameter(SimConfig& cfg, std::string_view name, double value) {
  for (const auto& f : fields()) {
    if (name == f.name) {
      check_domain(name, value, f.domain);
      f.ref(cfg) = value;
      return;
    }
  }
  if (set_extension_parameter(cfg.extension, name, value)) return;
  if (name == "v_a") {
    check_domain(name, value, Domain::kNonNegative);
    if (cfg.stages.size() < 2)
      throw InvalidParameter("v_a", value, "needs a run with at least two stages");
    for (std::size_t i = 1; i < cfg.stages.size(); ++i) cfg.stages[i].v_a = value;
    return;
  }
  if (name == "f") {
    check_domain(name, value, Domain::kPositive);
    for (auto& s : cfg.stages) s.f = value;
    return;
  }
  if (name == "t_on") {
    check_domain(name, value, Domain::kPositive);
    if (cfg.stages.size() < 2)
      throw InvalidParameter("t_on", value, "needs a run with at least two stages");
    const double total = cfg.total_duration();
    if (!(value < total))
      throw InvalidParameter("t_on", value, "must be less than the run duration " + fmt(total));
    // Keep the run's end time: stage 2 absorbs the change.
    cfg.stages[1].duration += cfg.stages[0].duration - value;
    cfg.stages[0].duration = value;
    return;
  }
  if (name == "duration") {
    check_domain(name, value, Domain::kPositive);
    if (cfg.stages.size() == 1) {
      cfg.stages[0].duration = value;
      return;
    }
    const double t_on = cfg.stages[0].duration;
    if (!(value > t_on))
      throw InvalidParameter("duration", value,
                             "must exceed t_on = " + fmt(t_on) + " (the still-base stage)");
    double rest = cfg.total_duration() - t_on;
    for (std::size_t i = 1; i < cfg.stages.size(); ++i)
      cfg.stages[i].duration *= (value - t_on) / rest;
    return;
  }
  std::size_t i = 0;
  std::string_view field;
  if (parse_stage_name(name, &i, &field)) {
    require_stage(cfg, name, i, value);
    if (field == "duration") {
      check_domain(name, value, Domain::kPositive);
      cfg.stages[i].duration = value;
      return;
    }
    if (field == "v_a") {
      check_domain(name, value, Domain::kNonNegative);
      cfg.stages[i].v_a = value;
      return;
    }
    if (field == "f") {
      check_domain(name, value, Domain::kPositive);
      cfg.stages[i].f = value;
      return;
    }
  }
  throw InvalidParameter(std::string(name), value, "unknown parameter");
}

double get_parameter(const SimConfig& cfg_in, std::string_view name) {
  SimConfig& cfg = const_cast<SimConfig&>(cfg_in);  // fields() hands out mutable refs; we only read
  for (const auto& f : fields())
    if (name == f.name) return f.ref(cfg);
  if (double v = 0; get_extension_parameter(cfg.extension, name, &v)) return v;
  if (name == "v_a") return cfg.stages.size() > 1 ? cfg.stages.back().v_a : 0.0;
  if (name == "f") return cfg.stages.empty() ? 0.0 : cfg.stages.back().f;
  if (name == "t_on") return cfg.stages.size() > 1 ? cfg.stages[0].duration : cfg.total_duration();
  if (name == "duration") return cfg.total_duration();
  std::size_t i = 0;
  std::string_view field;
  if (parse_stage_name(name, &i, &field) && i < cfg.stages.size()) {
    if (field == "duration") return cfg.stages[i].duration;
    if (field == "v_a") return cfg.stages[i].v_a;
    if (field == "f") return cfg.stages[i].f;
  }
  throw InvalidParameter(std::string(name), std::string(name), "unknown parameter");
}

std::vector<std::string> parameter_names() {
  std::vector<std::string> out;
  for (const auto& f : fields()) out.emplace_back(f.name);
  for (const char* n : {"v_a", "f", "t_on", "duration"}) out.emplace_back(n);
  for (int i = 1; i <= 2; ++i)
    for (const char* n : {"duration", "v_a", "f"})
      out.push_back("stage" + std::to_string(i) + "." + n);
  for (auto& n : all_extension_parameter_names()) out.push_back(std::move(n));
  return out;
}

void set_extension(SimConfig& cfg, std::string_view effect) {
  cfg.extension.kind = extension_from_string(effect);
}

}  // namespace stickslip::engine
