#pragma once
// Parameters of the seed's system (Rybkiewicz & Leus, "Selection of the Friction Model for
// Numerical Analyses of the Impact of Longitudinal Vibration on Stick-Slip Movement"; equations
// 1-22, Table 1). All values are SI: kg, N, m, s, N/m, N s/m, m/s, Hz.
//
// Body A of mass m is pulled through a drive spring k_d whose far end moves at v_d:
//     F_d = k_d (v_d t - x)            (2)
//     m x'' = F_d - F_f                (1)
// The base B moves as u = u0 sin(w t'), u' = v_a cos(w t'), w = 2 pi f   (3)-(6)
// where t' is the time since the start of the stage that switched vibration on (so the base is at
// its centre, moving forward at +v_a, when the vibration starts; this equals the seed's absolute
// phase whenever f * t_on is an integer, as for t_on = 10 s and f = 1500 Hz).
// The friction models see the relative velocity v_r = x' - u'     (10)
//
// Every field is validated when it is set through set_parameter(), and again as a whole by
// SimConfig::IsValid(), which also checks the cross-field constraints (F_S >= F_C, ...).

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "stickslip/engine/extensions.h"
#include "stickslip/engine/invalid_parameter.h"
#include "stickslip/engine/model_api.h"
#include "stickslip/engine/registry.h"

namespace stickslip::engine {

enum class IntegratorKind {
  kRk4,       ///< fixed-step classic RK4, the seed's ode4. Switching is not located.
  kRk4Event,  ///< fixed-step RK4 that locates stick/slip switches (Karnopp, Reset Integrator).
  kAdaptive,  ///< adaptive-step RK (Dormand-Prince 5(4)) with the bristle equation advanced
              ///< exactly by an integrating factor, and located switches. Our default.
};
static_assert(kAdaptiveOnly == 1u << static_cast<int>(IntegratorKind::kAdaptive));
const char* to_string(IntegratorKind k) noexcept;
IntegratorKind integrator_from_string(std::string_view name);

/// The friction parameters and options of every registered model (registry.h), by name: each
/// model reads the ones in its traits table, and a parameter shared by several models (F_C, k_t
/// ...) is one value. Defaults are the models' tables' (the seed's Table 1).
class FrictionParams {
 public:
  FrictionParams() noexcept;
  /// The parameter (or alias, e.g. F_slip = F_C) by name; InvalidParameter for an unknown name.
  double& operator[](std::string_view name);
  double operator[](std::string_view name) const;
  /// By position in kFrictionParameters.
  double value(std::size_t index) const noexcept { return values_[index]; }
  double& value(std::size_t index) noexcept { return values_[index]; }
  /// An option's choice index by name (see kFrictionOptions); InvalidParameter when unknown.
  int option(std::string_view name) const;
  int option_at(std::size_t index) const noexcept { return options_[index]; }
  /// Sets an option by the name of the choice; InvalidParameter naming the option and value.
  void set_option(std::string_view name, std::string_view choice);
  bool operator==(const FrictionParams&) const = default;

 private:
  std::array<double, kFrictionParameters.size()> values_;
  std::array<int, kFrictionOptions.size()> options_;
};

/// One stage of a run: a duration and a vibration setting. v_a == 0 means the base is still.
struct Stage {
  double duration = 10.0;  ///< [s]
  double v_a = 0.0;        ///< base velocity amplitude [m/s]
  double f = 1500.0;       ///< base frequency [Hz]
  bool vibrating() const noexcept { return v_a > 0.0; }
  bool operator==(const Stage&) const = default;
};

struct IntegratorOptions {
  IntegratorKind kind = IntegratorKind::kAdaptive;
  double dt = 1.0e-6;      ///< fixed step for rk4 / rk4_event [s]; initial step for adaptive
  // Adaptive error control is done in force units: the local errors of x, x' and the model's
  // internal states are weighed as k_d |dx| and by the model's error_weights (sqrt(k m) |dx'|,
  // k_t |ds| ...) [N] and kept below atol + rtol * F_ref, F_ref the model's force scale
  // (default max(F_S, F_C), the contact's friction level).
  double rtol = 1.0e-7;    ///< adaptive: relative local tolerance [-]
  double atol = 1.0e-7;    ///< adaptive: absolute local tolerance [N]
  // dt_max: the adaptive integrator's largest step [s]. GMS in a stage without base vibration
  // (v_a = 0, no extension) steps up to 3 dt_max, at most one trace interval (1 / trace.rate),
  // never below dt_max: the still stage is otherwise limited by dt_max alone (F_d within 1.5e-5
  // of F_ref at every rtol, docs/engine.md). Every other model and stage: at most dt_max.
  double dt_max = 1.0e-4;  ///< adaptive: largest step [s] (GMS on a still base: see above)
  double max_steps = 2e9;  ///< safety cap on the number of steps in a run [-]
  bool operator==(const IntegratorOptions&) const = default;
};

struct MetricOptions {
  double settle_fraction = 0.4;      ///< judge each stage over its last (1 - this) part [-]
  double cycle_threshold = 0.2;      ///< smallest F_d drop that counts as a slip [N]
  bool operator==(const MetricOptions&) const = default;
};

struct TraceOptions {
  double rate = 0.0;  ///< samples per second; 0 = no trace [Hz]
  bool operator==(const TraceOptions&) const = default;
};

/// The whole specification of one simulation run.
struct SimConfig {
  ModelKind model = model_kind<LuGre>;
  Drive drive;
  FrictionParams friction;
  std::vector<Stage> stages = {Stage{10.0, 0.0, 1500.0}, Stage{10.0, 0.0, 1500.0}};
  IntegratorOptions integrator;
  MetricOptions metrics;
  TraceOptions trace;
  Extension extension;  ///< catalogue effect added to the model (default none; extensions.h)

  /// The seed's default two-stage run: 10 s still, then 10 s vibrating at v_a [m/s], 1500 Hz.
  static SimConfig seed(ModelKind model, double v_a);

  /// True if every field and every cross-field constraint holds. Otherwise appends one message
  /// per broken constraint ("field: value ...") to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
  /// Throws InvalidParameter for the first broken constraint.
  void Validate() const;
  double total_duration() const noexcept;
};

/// Sets one parameter by its public name, validating its own domain (finite, > 0, ...).
/// Names: m, k_d, v_d, F_z, every friction parameter of every model and its alias
/// (kFrictionParameters: k_t, F_C, F_slip, F_S, ...), dt, rtol, atol, dt_max, v_a (every stage
/// after the first: the seed's stage 1 is always the still base), f (every stage), t_on (start
/// of stage 2 = duration of stage 1), duration (whole run; stage 1 keeps t_on when possible,
/// the rest is stage 2..n in proportion), stage<i>.duration, stage<i>.v_a, stage<i>.f (i from 1), settle_fraction, cycle_threshold,
/// and the extension parameters (sigma2, stribeck_delta, dwell_A, ..., c_d; see extensions.h;
/// the effect itself is chosen with set_extension).
/// Throws InvalidParameter naming the field and the value.
void set_parameter(SimConfig& cfg, std::string_view name, double value);
/// Sets a model option (kFrictionOptions) by the name of its choice, e.g. ("law", "slip").
void set_option(SimConfig& cfg, std::string_view name, std::string_view choice);
/// The name of an option's current choice.
std::string get_option(const SimConfig& cfg, std::string_view name);
/// Chooses the catalogue effect by id ("none", "viscous", ...); its parameters keep their values.
void set_extension(SimConfig& cfg, std::string_view effect);
/// Reads a parameter by the same names (throws InvalidParameter for an unknown name).
double get_parameter(const SimConfig& cfg, std::string_view name);
/// All names accepted by set_parameter for any configuration (the fixed ones, plus stage1.*,
/// stage2.* ...).
std::vector<std::string> parameter_names();

/// Model M of cfg: its parameters validated against its table (InvalidParameter naming the field
/// and the value), its options and the run's drive.
template <class M>
M make_model(const SimConfig& cfg);

/// The run's force scale F_ref [N]: the model's own (force_scale()) when it has one, else the
/// contact's friction level max(F_S, F_C). The adaptive tolerance is atol + rtol F_ref.
double force_scale(const SimConfig& cfg);

// ------------------------------------------------------------------ implementation

/// "%.17g": the number as InvalidParameter prints it.
std::string format_number(double v);

/// Calls fail(field, value, why) for every parameter of M outside its allowed range and every
/// broken constraint of M; returns false when it called it.
template <class M, class Fail>
bool visit_model_errors(const FrictionParams& p, Fail&& fail) {
  bool ok = true;
  for (std::size_t i = 0; i < std::size(M::kParams); ++i) {
    const double v = p.value(static_cast<std::size_t>(kParamSlots<M>[i]));
    if (std::string why = M::kParams[i].allowed.why_not(v); !why.empty()) {
      ok = false;
      fail(M::kParams[i].name, v, why);
    }
  }
  for (const Constraint& c : registry_detail::constraints_of<M>()) {
    const double a = p[c.param], b = p[c.at_least];
    if (a == a && b == b && a < b) {  // NaN is reported above
      ok = false;
      fail(c.param, a, std::string("must be >= ") + c.at_least + " = " + format_number(b));
    }
  }
  return ok;
}

template <class M>
bool check_model(const FrictionParams& p, std::vector<std::string>* errors) {
  return visit_model_errors<M>(p, [&](const char* field, double v, const std::string& why) {
    if (errors) errors->push_back(std::string(field) + " = " + format_number(v) + ": " + why);
  });
}

template <class M>
M make_model(const SimConfig& cfg) {
  visit_model_errors<M>(cfg.friction, [](const char* field, double v, const std::string& why) {
    throw InvalidParameter(field, v, why);
  });
  std::array<double, std::size(M::kParams)> values;
  for (std::size_t i = 0; i < values.size(); ++i)
    values[i] = cfg.friction.value(static_cast<std::size_t>(kParamSlots<M>[i]));
  constexpr auto option_defs = registry_detail::options_of<M>();
  std::array<int, option_defs.size()> options;
  for (std::size_t i = 0; i < options.size(); ++i)
    options[i] = cfg.friction.option_at(static_cast<std::size_t>(kOptionSlots<M>[i]));
  return M(ModelInputs(M::kParams, values, option_defs, options, cfg.drive));
}

}  // namespace stickslip::engine
