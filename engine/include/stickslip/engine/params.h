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

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "stickslip/engine/extensions.h"

namespace stickslip::engine {

/// Error for a bad user-supplied value. what() names the field and the value.
class InvalidParameter : public std::invalid_argument {
 public:
  InvalidParameter(std::string field, double value, const std::string& why);
  InvalidParameter(std::string field, const std::string& value, const std::string& why);
  const std::string& field() const noexcept { return field_; }

 private:
  std::string field_;
};

enum class ModelKind { kDahl, kKarnopp, kResetIntegrator, kLuGre };
const char* to_string(ModelKind m) noexcept;
/// "dahl", "karnopp", "reset_integrator", "lugre"; throws InvalidParameter("model", ...).
ModelKind model_from_string(std::string_view name);

enum class IntegratorKind {
  kRk4,       ///< fixed-step classic RK4, the seed's ode4. Switching is not located.
  kRk4Event,  ///< fixed-step RK4 that locates stick/slip switches (Karnopp, Reset Integrator).
  kAdaptive,  ///< adaptive-step RK (Dormand-Prince 5(4)) with the bristle equation advanced
              ///< exactly by an integrating factor, and located switches. Our default.
};
const char* to_string(IntegratorKind k) noexcept;
IntegratorKind integrator_from_string(std::string_view name);

/// Drive and body (seed values).
struct Drive {
  double m = 0.665;      ///< body mass [kg]
  double k_d = 11700.0;  ///< drive stiffness [N/m]
  double v_d = 1.0e-3;   ///< drive velocity [m/s]
  double F_z = 29.4;     ///< external load [N]; informational (F_C and F_S are given directly)
  bool operator==(const Drive&) const = default;
};

/// Friction parameters, flat: each model reads the fields it uses (Table 1 defaults).
///   Dahl:             k_t, kappa, F_C
///   Karnopp:          DV, F_S, F_C (the seed's F_slip; "F_slip" is accepted as an alias)
///   Reset Integrator: k_t, beta, s0, alpha
///   LuGre:            k_t, h_t, h_v, F_C, F_S, v_s
struct FrictionParams {
  double k_t = 71.318e6;  ///< tangential contact stiffness [N/m]
  double kappa = 1.0;     ///< Dahl exponent [-]
  double F_C = 8.3;       ///< Coulomb (sliding) friction force [N]; Karnopp's F_slip
  double F_S = 11.1;      ///< static friction force [N]
  double DV = 1.0e-5;     ///< Karnopp zero-velocity band half-width [m/s] (0.01 mm/s)
  double beta = 4.869e3;  ///< Reset Integrator damping [N s/m] (eq. 15 gives 0.707 sqrt(k_t m))
  double s0 = 1.1e-7;     ///< Reset Integrator maximum elastic strain [m] (1.1e-4 mm)
  double alpha = 0.34;    ///< Reset Integrator stiction gain a [-]
  double h_t = 1.377e4;   ///< LuGre bristle damping [N s/m] (eq. 21 with zeta = 1)
  double h_v = 0.0;       ///< LuGre viscous damping [N s/m]
  double v_s = 3.5e-4;    ///< LuGre Stribeck velocity [m/s]
  bool operator==(const FrictionParams&) const = default;
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
  // Adaptive error control is done in force units: the local error of x, x' and s is weighed as
  // k_d |dx|, sqrt(k m) |dx'| and k_t |ds| [N] and kept below atol + rtol * max(F_S, F_C).
  double rtol = 1.0e-7;    ///< adaptive: relative local tolerance [-]
  double atol = 1.0e-7;    ///< adaptive: absolute local tolerance [N]
  double dt_max = 1.0e-4;  ///< adaptive: largest step [s]
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
  ModelKind model = ModelKind::kLuGre;
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
/// Names: model (use set_model), m, k_d, v_d, F_z, k_t, kappa, F_C, F_slip, F_S, DV, beta, s0,
/// alpha, h_t, h_v, v_s, dt, rtol, dt_max, v_a (every stage after the first: the seed's stage 1
/// is always the still base), f (every stage), t_on (start of stage 2 = duration of stage 1),
/// duration (whole run; stage 1 keeps t_on when possible, the rest is stage 2..n in proportion),
/// stage<i>.duration, stage<i>.v_a, stage<i>.f (i from 1), settle_fraction, cycle_threshold,
/// and the extension parameters (sigma2, stribeck_delta, dwell_A, ..., c_d; see extensions.h;
/// the effect itself is chosen with set_extension).
/// Throws InvalidParameter naming the field and the value.
void set_parameter(SimConfig& cfg, std::string_view name, double value);
/// Chooses the catalogue effect by id ("none", "viscous", ...); its parameters keep their values.
void set_extension(SimConfig& cfg, std::string_view effect);
/// Reads a parameter by the same names (throws InvalidParameter for an unknown name).
double get_parameter(const SimConfig& cfg, std::string_view name);
/// All names accepted by set_parameter for any configuration (the fixed ones, plus stage1.*,
/// stage2.* ...).
std::vector<std::string> parameter_names();

}  // namespace stickslip::engine
