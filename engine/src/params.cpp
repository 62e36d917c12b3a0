#include "stickslip/engine/params.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

namespace stickslip::engine {
namespace {

// The configuration's own scalar fields (the friction parameters come from the registry).
struct Field {
  const char* name;
  Interval allowed;
  double& (*ref)(SimConfig&);
};

const std::vector<Field>& fields() {
  static const std::vector<Field> kFields = {
      {"m", kPositive, [](SimConfig& c) -> double& { return c.drive.m; }},
      {"k_d", kPositive, [](SimConfig& c) -> double& { return c.drive.k_d; }},
      {"v_d", kPositive, [](SimConfig& c) -> double& { return c.drive.v_d; }},
      // >= 0: a slider loaded by its weight alone has F_z = 0 (e.g. the Colas et al. rig).
      {"F_z", kNonNegative, [](SimConfig& c) -> double& { return c.drive.F_z; }},
      {"dt", kPositive, [](SimConfig& c) -> double& { return c.integrator.dt; }},
      {"rtol", kPositive, [](SimConfig& c) -> double& { return c.integrator.rtol; }},
      {"atol", kPositive, [](SimConfig& c) -> double& { return c.integrator.atol; }},
      {"dt_max", kPositive, [](SimConfig& c) -> double& { return c.integrator.dt_max; }},
      {"settle_fraction", kFraction,
       [](SimConfig& c) -> double& { return c.metrics.settle_fraction; }},
      {"cycle_threshold", kPositive,
       [](SimConfig& c) -> double& { return c.metrics.cycle_threshold; }},
  };
  return kFields;
}

const Field* find_field(std::string_view name) {
  for (const auto& f : fields())
    if (name == f.name) return &f;
  return nullptr;
}

void check(std::string_view name, double v, const Interval& allowed) {
  if (std::string why = allowed.why_not(v); !why.empty())
    throw InvalidParameter(std::string(name), v, why);
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

// The model-level checks of IsValid: constraints, integrator, effects.
void check_model_choice(const SimConfig& c, const std::function<void(const std::string&)>& fail) {
  const ModelTraits& t = model_traits(c.model);
  for (const Constraint& k : t.constraints) {
    const double a = c.friction[k.param], b = c.friction[k.at_least];
    if (std::isfinite(a) && std::isfinite(b) && a < b)
      fail(std::string(k.param) + " = " + format_number(a) + ": must be >= " + k.at_least +
           " = " + format_number(b));
  }
  if (!t.accepts(static_cast<int>(c.integrator.kind))) {
    std::string accepted;
    for (auto k : {IntegratorKind::kRk4, IntegratorKind::kRk4Event, IntegratorKind::kAdaptive})
      if (t.accepts(static_cast<int>(k)))
        accepted += (accepted.empty() ? "" : ", ") + std::string(to_string(k));
    fail(std::string("integrator = \"") + to_string(c.integrator.kind) + "\": model " +
         t.info->name + " does not run with it (accepts " + accepted + ")");
  }
  if (c.extension.active() && !t.info->effects)
    fail(std::string("effect = \"") + to_string(c.extension.kind) + "\": model " + t.info->name +
         " supports no catalogue effect");
}

}  // namespace

std::string format_number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

InvalidParameter::InvalidParameter(std::string field, double value, const std::string& why)
    : std::invalid_argument(field + " = " + format_number(value) + ": " + why),
      field_(std::move(field)) {}
InvalidParameter::InvalidParameter(std::string field, const std::string& value,
                                   const std::string& why)
    : std::invalid_argument(field + " = \"" + value + "\": " + why), field_(std::move(field)) {}

// ------------------------------------------------------------------ FrictionParams

FrictionParams::FrictionParams() noexcept {
  for (std::size_t i = 0; i < values_.size(); ++i) values_[i] = kFrictionParameters[i].def;
  for (std::size_t i = 0; i < options_.size(); ++i) options_[i] = kFrictionOptions[i].def;
}

double& FrictionParams::operator[](std::string_view name) {
  const int i = friction_parameter_index(name);
  if (i < 0)
    throw InvalidParameter(std::string(name), std::string(name), "unknown friction parameter");
  return values_[static_cast<std::size_t>(i)];
}

double FrictionParams::operator[](std::string_view name) const {
  return const_cast<FrictionParams&>(*this)[name];
}

int FrictionParams::option(std::string_view name) const {
  const int i = friction_option_index(name);
  if (i < 0) throw InvalidParameter(std::string(name), std::string(name), "unknown model option");
  return options_[static_cast<std::size_t>(i)];
}

void FrictionParams::set_option(std::string_view name, std::string_view choice) {
  const int i = friction_option_index(name);
  if (i < 0 || kFrictionOptions.empty())
    throw InvalidParameter(std::string(name), std::string(choice), "unknown model option");
  const OptionDef& d = kFrictionOptions[static_cast<std::size_t>(i)];
  std::string all;
  for (std::size_t k = 0; k < d.choices.size(); ++k) {
    if (choice == d.choices[k]) {
      options_[static_cast<std::size_t>(i)] = static_cast<int>(k);
      return;
    }
    all += (k ? ", " : "") + std::string(d.choices[k]);
  }
  throw InvalidParameter(std::string(name), std::string(choice), "expected one of " + all);
}


// ------------------------------------------------------------------ SimConfig

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
  for (const auto& f : fields())
    if (std::string why = f.allowed.why_not(f.ref(copy)); !why.empty())
      fail(std::string(f.name) + " = " + format_number(f.ref(copy)) + ": " + why);
  for (std::size_t i = 0; i < kFrictionParameters.size(); ++i)
    if (std::string why = kFrictionParameters[i].allowed.why_not(friction.value(i)); !why.empty())
      fail(std::string(kFrictionParameters[i].name) + " = " + format_number(friction.value(i)) +
           ": " + why);
  check_model_choice(*this, fail);
  if (stages.empty()) fail("stages: a run needs at least one stage");
  for (std::size_t i = 0; i < stages.size(); ++i) {
    const std::string p = "stage" + std::to_string(i + 1) + ".";
    const auto& s = stages[i];
    if (!std::isfinite(s.duration) || !(s.duration > 0))
      fail(p + "duration = " + format_number(s.duration) + ": must be a finite number > 0");
    if (!std::isfinite(s.v_a) || !(s.v_a >= 0))
      fail(p + "v_a = " + format_number(s.v_a) + ": must be a finite number >= 0");
    if (!std::isfinite(s.f) || !(s.f > 0))
      fail(p + "f = " + format_number(s.f) + ": must be a finite number > 0");
  }
  const auto& in = integrator;
  if (std::isfinite(in.dt) && in.dt > 0 && std::isfinite(total_duration()) &&
      total_duration() / in.dt > in.max_steps && in.kind != IntegratorKind::kAdaptive)
    fail("dt = " + format_number(in.dt) + ": needs more than max_steps = " +
         format_number(in.max_steps) + " steps");
  if (!std::isfinite(in.atol) || !(in.atol > 0))
    fail("atol = " + format_number(in.atol) + ": must be a finite number > 0");
  // x_max: sliding distance of the run, about v_d times its duration [m]; v_max: the drive
  // plus the largest vibration velocity [m/s], reached by |v_r| in every vibrating period.
  double v_max = std::fabs(drive.v_d);
  double v_a_max = 0.0;
  for (const auto& s : stages)
    if (std::isfinite(s.v_a)) v_a_max = std::max(v_a_max, s.v_a);
  v_max += v_a_max;
  if (!extension.IsValid(errors, drive.v_d * total_duration(),
                         std::isfinite(v_max) ? v_max : 0.0))
    ok = false;
  if (std::isfinite(trace.rate) ? trace.rate < 0 : true)
    fail("trace_rate = " + format_number(trace.rate) + ": must be a finite number >= 0");
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

// ------------------------------------------------------------------ by name

void set_parameter(SimConfig& cfg, std::string_view name, double value) {
  if (const Field* f = find_field(name)) {
    check(name, value, f->allowed);
    f->ref(cfg) = value;
    return;
  }
  if (const int i = friction_parameter_index(name); i >= 0) {
    check(name, value, kFrictionParameters[static_cast<std::size_t>(i)].allowed);
    cfg.friction.value(static_cast<std::size_t>(i)) = value;
    return;
  }
  if (set_extension_parameter(cfg.extension, name, value)) return;
  if (name == "v_a") {
    check(name, value, kNonNegative);
    if (cfg.stages.size() < 2)
      throw InvalidParameter("v_a", value, "needs a run with at least two stages");
    for (std::size_t i = 1; i < cfg.stages.size(); ++i) cfg.stages[i].v_a = value;
    return;
  }
  if (name == "f") {
    check(name, value, kPositive);
    for (auto& s : cfg.stages) s.f = value;
    return;
  }
  if (name == "t_on") {
    check(name, value, kPositive);
    if (cfg.stages.size() < 2)
      throw InvalidParameter("t_on", value, "needs a run with at least two stages");
    const double total = cfg.total_duration();
    if (!(value < total))
      throw InvalidParameter("t_on", value,
                             "must be less than the run duration " + format_number(total));
    // Keep the run's end time: stage 2 absorbs the change.
    cfg.stages[1].duration += cfg.stages[0].duration - value;
    cfg.stages[0].duration = value;
    return;
  }
  if (name == "duration") {
    check(name, value, kPositive);
    if (cfg.stages.size() == 1) {
      cfg.stages[0].duration = value;
      return;
    }
    const double t_on = cfg.stages[0].duration;
    if (!(value > t_on))
      throw InvalidParameter("duration", value,
                             "must exceed t_on = " + format_number(t_on) +
                                 " (the still-base stage)");
    double rest = cfg.total_duration() - t_on;
    for (std::size_t i = 1; i < cfg.stages.size(); ++i)
      cfg.stages[i].duration *= (value - t_on) / rest;
    return;
  }
  std::size_t i = 0;
  std::string_view field;
  if (parse_stage_name(name, &i, &field)) {
    require_stage(cfg, name, i, value);
    const Interval allowed = field == "v_a" ? kNonNegative : kPositive;
    double* target = field == "duration" ? &cfg.stages[i].duration
                     : field == "v_a"    ? &cfg.stages[i].v_a
                     : field == "f"      ? &cfg.stages[i].f
                                         : nullptr;
    if (target) {
      check(name, value, allowed);
      *target = value;
      return;
    }
  }
  throw InvalidParameter(std::string(name), value, "unknown parameter");
}

double get_parameter(const SimConfig& cfg, std::string_view name) {
  if (const Field* f = find_field(name)) {
    SimConfig copy = cfg;  // Field hands out mutable references
    return f->ref(copy);
  }
  if (const int i = friction_parameter_index(name); i >= 0)
    return cfg.friction.value(static_cast<std::size_t>(i));
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

void set_option(SimConfig& cfg, std::string_view name, std::string_view choice) {
  cfg.friction.set_option(name, choice);
}

std::string get_option(const SimConfig& cfg, std::string_view name) {
  const int i = friction_option_index(name);
  if constexpr (!kFrictionOptions.empty()) {
    if (i >= 0) {
      const OptionDef& d = kFrictionOptions[static_cast<std::size_t>(i)];
      const int choice = cfg.friction.option_at(static_cast<std::size_t>(i));
      return d.choices[static_cast<std::size_t>(choice)];
    }
  }
  throw InvalidParameter(std::string(name), std::string(name), "unknown model option");
}

std::vector<std::string> parameter_names() {
  std::vector<std::string> out;
  for (const auto& f : fields()) out.emplace_back(f.name);
  for (const ParamDef& p : kFrictionParameters) {
    out.emplace_back(p.name);
    if (p.alias) out.emplace_back(p.alias);
  }
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
