#pragma once
// The vocabulary of a friction-model header (engine/include/stickslip/engine/models/*.h): the
// traits-table types (parameters with unit, dimension, default, allowed and fit range; options;
// constraints), the run's conditions a model may read, the integrators' state and the value
// types of a right-hand side. docs/engine.md "Adding a friction model" says how they fit.
//
// SI units throughout. A physical dimension is written as exponents of force [N], length [m] and
// time [s]: the unit string is derived from it, and the diagnosis scales a parameter from a
// record's own scales by it (force F*, length F*/k_d, time (F*/k_d)/v_d).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <string_view>

#include "stickslip/engine/exp.h"

namespace stickslip::engine {

// ------------------------------------------------------------------ traits-table types

/// Physical dimension: force^N length^L time^T.
struct Dim {
  std::int8_t force = 0, length = 0, time = 0;
  constexpr bool operator==(const Dim&) const = default;
};
inline constexpr Dim kDimensionless{0, 0, 0};
inline constexpr Dim kForce{1, 0, 0};        ///< N
inline constexpr Dim kLength{0, 1, 0};       ///< m
inline constexpr Dim kTime{0, 0, 1};         ///< s
inline constexpr Dim kVelocity{0, 1, -1};    ///< m/s
inline constexpr Dim kStiffness{1, -1, 0};   ///< N/m
inline constexpr Dim kDamping{1, -1, 1};     ///< N s/m
inline constexpr Dim kForceRate{1, 0, -1};   ///< N/s
/// "N/m", "N s/m", "m/s", "-" ... (numerator factors, then "/" and the denominator's).
std::string unit_of(Dim d);

/// An allowed interval of values. Every parameter must also be finite.
struct Interval {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = true, hi_open = true;
  /// Whole numbers only (an integer-valued parameter such as an element count).
  bool integer = false;
  constexpr bool contains(double v) const noexcept {
    constexpr double inf = std::numeric_limits<double>::infinity();
    if (!(v == v) || v == inf || v == -inf) return false;
    if (lo_open ? !(v > lo) : !(v >= lo)) return false;
    if (hi_open ? !(v < hi) : !(v <= hi)) return false;
    return !integer ||
           (v > -9e15 && v < 9e15 && v == static_cast<double>(static_cast<long long>(v)));
  }
  /// Empty when v is allowed, else why not: "must be a finite number", "must be > 0", "must be
  /// >= 0", "must be in [0, 1)", "must be a whole number" ...
  std::string why_not(double v) const;
};
inline constexpr Interval kPositive{0.0, std::numeric_limits<double>::infinity(), true, true};
inline constexpr Interval kNonNegative{0.0, std::numeric_limits<double>::infinity(), false, true};
inline constexpr Interval kFraction{0.0, 1.0, false, true};  ///< [0, 1)
inline constexpr Interval kAnyFinite{};

/// Measured force levels a fit starts from [N]: the sliding level (stage-1 mean) and the
/// breakaway level (mean + half the peak-to-peak amplitude).
struct FitLevels {
  double slip = 0.0, stick = 0.0;
};
using FitStart = double (*)(const FitLevels&);
enum class FitScale { kLinear, kLog };

/// How the diagnosis fits a parameter (a parameter with lo == hi is not fitted). relative_to:
/// fit the ratio name/relative_to in [lo, hi] instead of the value (the fit parameter is named
/// "F_C/F_S"), which keeps the constraint name <= relative_to. start: the starting value from
/// the measured levels (the ratio's, when relative); nullptr starts from the default.
/// per_normal_load: a dimensionless coefficient of the normal load (rate-and-state's mu0, a, b:
/// F_f = F_N mu). Its range and start are written for Table 1 (levels of ~10 N at F_N = 35.9 N);
/// the diagnosis moves them by the record's force level over its F_N (diagnose_scale.h).
struct FitRange {
  double lo = 0.0, hi = 0.0;
  FitScale scale = FitScale::kLinear;
  FitStart start = nullptr;
  const char* relative_to = nullptr;
  bool per_normal_load = false;
  constexpr bool fitted() const noexcept { return hi > lo; }
};

/// One parameter of a model's traits table.
struct ParamDef {
  const char* name;         ///< the set_parameter name, e.g. "k_t"
  Dim dim;                  ///< physical dimension (gives the unit)
  double def;               ///< default [SI]
  Interval allowed;         ///< validated on set and by SimConfig::IsValid
  const char* description;  ///< one line, without the unit
  FitRange fit{};           ///< model-specific (see with_fit); not fitted by default
  const char* alias = nullptr;  ///< a second accepted name (e.g. the seed's "F_slip")
  /// The same parameter, fitted as given (a model's row of a parameter it shares).
  constexpr ParamDef with_fit(FitRange f) const noexcept {
    ParamDef p = *this;
    p.fit = f;
    return p;
  }
  /// True when a and b describe the same parameter (everything but the fit, which is per model).
  friend constexpr bool same_parameter(const ParamDef& a, const ParamDef& b) noexcept {
    return std::string_view(a.name) == b.name && a.dim == b.dim && a.def == b.def &&
           a.allowed.lo == b.allowed.lo && a.allowed.hi == b.allowed.hi &&
           a.allowed.lo_open == b.allowed.lo_open && a.allowed.hi_open == b.allowed.hi_open &&
           a.allowed.integer == b.allowed.integer &&
           std::string_view(a.description) == b.description &&
           std::string_view(a.alias ? a.alias : "") == (b.alias ? b.alias : "");
  }
};

/// A model option that is not a number: one of a few named choices (e.g. the rate-and-state
/// "law": aging or slip). Stored as the choice's index. Part of the model's identity (a batch
/// and a checkpoint share it).
struct OptionDef {
  const char* name;
  std::span<const char* const> choices;
  int def;  ///< index into choices
  const char* description;
};

/// A cross-parameter constraint: param >= at_least (e.g. F_S >= F_C), checked by IsValid.
struct Constraint {
  const char* param;
  const char* at_least;
};

/// Smooth models are integrated as they stand (the adaptive integrator's integrating factor and
/// reversal limiter apply); switching models through their hybrid form with located switches.
enum class ModelClass { kSmooth, kSwitching };

/// Integrators a model accepts (bit i: IntegratorKind i).
inline constexpr unsigned kAllIntegrators = 0x7u;
/// The adaptive integrator only (a model with its own Stepper; params.h checks the bit).
inline constexpr unsigned kAdaptiveOnly = 1u << 2;

/// The model's primary internal state: the trace's and the result's "s" [unit from dim].
struct StateInfo {
  const char* name = "s";
  Dim dim = kLength;
  const char* description = "bristle strain";
};

/// Everything about a model that is not its right-hand side.
struct ModelInfo {
  const char* name;       ///< id in specs, the CLI and the API ("lugre")
  const char* title;      ///< for humans ("LuGre")
  const char* reference;  ///< where its equations come from
  ModelClass model_class;
  StateInfo state{};
  /// nullptr when the model has a batched (vectorised lock-step RK4) kernel; otherwise why not.
  /// Batches of such a model run lane by lane through simulate().
  const char* scalar_only = nullptr;
  unsigned integrators = kAllIntegrators;
  /// Catalogue effects the model supports (extensions.h): true for all of them, or none.
  bool effects = true;
};

// ------------------------------------------------------------------ run conditions

/// Drive and body (the seed's values). The normal load F_N = F_z + m g is what models written per
/// unit normal load use (rate-and-state: F_f = F_N mu). F_z >= 0 is the external load on a
/// horizontal slider; 0 for a slider loaded by its weight alone.
struct Drive {
  double m = 0.665;      ///< body mass [kg]
  double k_d = 11700.0;  ///< drive stiffness [N/m]
  double v_d = 1.0e-3;   ///< drive velocity [m/s]
  double F_z = 29.4;     ///< external load [N]
  static constexpr double kGravity = 9.81;  ///< [m/s^2]
  double normal_load() const noexcept { return F_z + m * kGravity; }  ///< F_N [N]
  bool operator==(const Drive&) const = default;
};

/// What a model's constructor reads: its own parameters (already validated against its table),
/// its options and the run's conditions. Lookup by name; a name outside the model's table is a
/// programming error (std::logic_error).
class ModelInputs {
 public:
  ModelInputs(std::span<const ParamDef> defs, std::span<const double> values,
              std::span<const OptionDef> option_defs, std::span<const int> options,
              const Drive& drive) noexcept
      : defs_(defs), values_(values), option_defs_(option_defs), options_(options),
        drive_(drive) {}
  double operator[](std::string_view name) const;
  int option(std::string_view name) const;
  const Drive& drive() const noexcept { return drive_; }

 private:
  std::span<const ParamDef> defs_;
  std::span<const double> values_;
  std::span<const OptionDef> option_defs_;
  std::span<const int> options_;
  const Drive& drive_;
};

// ------------------------------------------------------------------ right-hand-side types

/// Most internal states a model may have.
inline constexpr int kMaxInternalStates = 16;

/// The integrators' state: body position x [m], velocity x' [m/s] and the model's Z internal
/// states: s, the first (the bristle strain of the seed's models; it stays 0 in a model without
/// internal states), and zs, the others (models with Z >= 2 only). internal(y, k) and
/// internal_states(y) give them by index.
template <int Z, bool kMore = (Z > 1)>
struct StateStorage {
  double x = 0.0;
  double v = 0.0;
  double s = 0.0;
};
template <int Z>
struct StateStorage<Z, true> {
  double x = 0.0;
  double v = 0.0;
  double s = 0.0;
  std::array<double, Z - 1> zs{};
};
/// (A model with no internal state has the same state type as one with one: s stays 0.)
template <int Z>
using StateT = StateStorage<(Z > 1 ? Z : 1), (Z > 1)>;

/// Internal state k of y (k < Z).
template <int Z, bool M>
double& internal(StateStorage<Z, M>& y, int k) noexcept {
  if constexpr (Z > 1) return k == 0 ? y.s : y.zs[static_cast<std::size_t>(k - 1)];
  else return y.s;
}
/// The internal states of y as the array a model's right-hand side reads.
template <int Z, bool M>
std::array<double, Z> internal_states(const StateStorage<Z, M>& y) noexcept {
  std::array<double, Z> z{};
  if constexpr (Z >= 1) z[0] = y.s;
  if constexpr (Z > 1)
    for (std::size_t k = 1; k < static_cast<std::size_t>(Z); ++k) z[k] = y.zs[k - 1];
  return z;
}

/// Friction force and strain rate of a model with at most one internal state s.
struct FrictionEval {
  double F_f;  ///< friction force on the body [N]
  double ds;   ///< s' [state unit / s] (0 for a model without internal states)
};
/// The same for a model with Z >= 2 internal states.
template <int Z>
struct FrictionEvalN {
  double F_f;                ///< friction force on the body [N]
  std::array<double, Z> dz;  ///< z' [state unit / s]
};

/// The base motion at one instant: u', u'' and u''' [m/s, m/s^2, m/s^3].
struct BaseMotion {
  double ub = 0.0, ab = 0.0, jb = 0.0;
};
/// An implicit system's right-hand side at one point, with the forces it came from [N].
template <int N>
struct ImplicitEval {
  std::array<double, N> f{};
  double F_d = 0.0, F_f = 0.0;
};
/// The same with the Jacobian J = df/dy and the explicit time derivative f_t = df/dt.
template <int N>
struct ImplicitLinear {
  std::array<double, N> f{}, f_t{};
  std::array<std::array<double, N>, N> J{};
  double F_d = 0.0, F_f = 0.0;
};

/// The engine's linearly implicit integrator for stiff models: Rosenbrock's RODAS4 (Hairer &
/// Wanner) with the exact Jacobian, adaptive steps and error control in force units
/// (engine/src/rosenbrock.h). A model chooses it with `using Stepper = RosenbrockStepper<M>;`
/// and provides the system it advances as M::Implicit, in coordinates of its choice (e.g.
/// rate-and-state advances mu/a instead of the velocity, see models/rate_state.h):
///
///   struct Implicit {
///     static constexpr int N;                          // dimension
///     Implicit(const M& model, const Drive& drive);
///     // From and to the engine's state (x [m], x' [m/s], internal states) at base motion b:
///     std::array<double, N> from_state(double x, double v, const std::array<double, Z>& z,
///                                      const BaseMotion& b) const;
///     void to_state(const std::array<double, N>& y, const BaseMotion& b, double* x, double* v,
///                   std::array<double, Z>* z) const;
///     ImplicitEval<N> eval(double t, const std::array<double, N>& y, const BaseMotion& b) const;
///     ImplicitLinear<N> linearise(double t, const std::array<double, N>& y,
///                                 const BaseMotion& b) const;
///     // N per unit of each component, at the step's start (y, b): set once per step
///     std::array<double, N> error_weights(int mode, const std::array<double, N>& y,
///                                         const BaseMotion& b) const;
///     // Modes (charts): the mode of an engine state, and the event that leaves a mode (>= 0
///     // inside, fires when < 0; y0, b0: the step's start), and what happens there: the next
///     // mode, y mapped into it and possibly advanced over dt <= dt_max by the system itself.
///     int mode_of(double v_r) const;
///     double event(int mode, const std::array<double, N>& y0, const BaseMotion& b0, double t,
///                  const std::array<double, N>& y, const BaseMotion& b) const;
///     // The predicted time until the mode's event (infinite: none): the step ends there.
///     // f = y' and fd = y'' (J f + f_t) at y.
///     double time_to_event(int mode, const std::array<double, N>& y,
///                          const std::array<double, N>& f, const std::array<double, N>& fd,
///                          const BaseMotion& b) const;
///     // The lowest event value accepted where an event is located (-inf: any).
///     double event_floor(int mode) const;
///     struct Jump { int mode; double dt; };
///     Jump enter(int mode, double t, std::array<double, N>& y, const BaseMotion& b,
///                double dt_max) const;
///   };
/// with a mode argument first in from_state, to_state, eval and linearise.
template <class M>
class RosenbrockStepper;

inline double sgn(double v) noexcept { return (v > 0.0) - (v < 0.0); }

/// Modulation of the friction law by a catalogue effect at one instant (extensions.h).
struct Mod {
  double level = 1.0;  ///< friction-level multiplier [-]
  double dFS = 0.0;    ///< static friction increase [N]
};

/// The constant coefficients of the active catalogue effect a model reads.
struct EffectTerms {
  double sigma2 = 0.0;  ///< viscous coefficient [N s/m]
  double delta = 2.0;   ///< Stribeck exponent [-]
};

/// Everything a friction law sees at one instant besides the state.
struct Point {
  double F_d;           ///< drive force [N]
  double v_r;           ///< relative velocity x' - u' [m/s]
  double a_b = 0.0;     ///< base acceleration u'' [m/s^2]
  Mod mod{};            ///< effect modulation
  double sigma2 = 0.0;  ///< effect: viscous coefficient [N s/m]
};

/// Weights turning the local errors into forces [N per unit]: x' (an impedance [N s/m]) and each
/// internal state. The x weight is the drive stiffness k_d for every model.
template <int Z>
struct ErrorWeights {
  double v;
  std::array<double, Z> z;
};

}  // namespace stickslip::engine
