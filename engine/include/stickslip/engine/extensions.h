#pragma once
// The catalogue of model extensions (issue 5): physical effects the seed's four models leave out,
// each a candidate cause when a calibrated model misses measured data. An Extension is a small
// value type carried in SimConfig (default: none) and applied inside the engine's friction
// evaluation, so simulate(), studies and the diagnosis all see the same physics.
//
// One effect at a time (kind); the parameters of the other effects must stay at their neutral
// defaults (IsValid reports a non-neutral parameter of an unselected effect, so a typo such as
// --effect viscous --effect-param dwell_A=1 is not silently ignored). SI units.
//
//   viscous                F_f += sigma2 v_r                                   sigma2 [N s/m] >= 0
//                          (Karnopp: slip branch only; stick is a reaction force)
//   stribeck_shape         LuGre Stribeck curve exp(-|v_r/v_s|^delta), delta > 0 (seed: 2).
//                          Dahl, Karnopp and the Reset Integrator have no Stribeck curve: inert.
//   dwell_time             static friction grows with the time the contact has been stuck:
//                          F_S(t_stick) = F_S0 + A ln(1 + t_stick/tau)   A [N] >= 0, tau [s] > 0
//                          t_stick = time since |v_r| was last above dwell_v [m/s] (after each
//                          accepted integrator step; 0 s at t = 0 means "stuck since the start").
//                          Karnopp/LuGre: F_S; Reset Integrator: breakaway force
//                          (1 + alpha) k_t s0 + A ln(...) (alpha raised by A ln(...)/(k_t s0));
//                          Dahl has no static friction: inert.
//   waviness               friction level along the track x [m]:
//                          F_C, F_S x (1 + eps sin(2 pi x / lambda + phi))
//                          eps in [0, 1), lambda [m] > 0, phi [rad]
//   drift                  friction level drifts with sliding distance (wear, heating):
//                          F_C, F_S x (1 + gamma x), gamma [1/m]; 1 + gamma x must stay > 0
//   normal_load_modulation while a stage vibrates, the normal load and so the friction level
//                          scale with 1 + eta sin(w t' + phi), t' the time since the vibration
//                          started (the base velocity is v_a cos(w t')). eta in [0, 1)
//   sensor_dynamics        the force sensor is a second-order system driven by the true F_d:
//                          y'' + 2 zeta omega_n y' + omega_n^2 y = omega_n^2 F_d, with
//                          omega_n = 1 / sensor_tau [rad/s]; sensor_tau = 0 is an ideal sensor.
//                          Only the *measured* signal changes: the trace's F_d is y, while the
//                          physics and the per-stage metrics use the true F_d.
//   drive_damping          F_d = k_d (v_d t - x) + c_d (v_d - x'),  c_d [N s/m] >= 0
//   velocity_weakening     steady sliding friction falls with the logarithm of the slip velocity,
//                          as real contacts show (paper on paper: Heslot et al. 1994):
//                          F_C, F_S x f(v_r), f = max(1 - vw_beta ln(1 + |v_r| / vw_v), 0.05)
//                          vw_beta in [0, 0.5) [-], vw_v [m/s] > 0 (reference velocity).
//                          f(0) = 1: a stuck contact keeps its level; the floor 0.05 is reached
//                          only at |v_r| >= vw_v (exp(0.95 / vw_beta) - 1), far above the slip
//                          velocities of a run (IsValid rejects a run whose drive and vibration
//                          velocities alone, v_d + max v_a, would reach it). Dahl: F_C x f, so
//                          its steady sliding force is F_C f(v_d); Karnopp: F_S inside the stick
//                          band (|v_r| <= DV, where f ~ 1) and F_slip x f while slipping; LuGre
//                          and elasto-plastic: F_C and F_S inside g(v_r), so the steady curve is
//                          f(v) (F_C + (F_S - F_C) exp(-|v/v_s|^2)) + h_v v; Reset Integrator:
//                          the whole contact force, and its sliding force k_t s0 f(v_r).
//                          Rate-and-state and GMS take no catalogue effect (rate-and-state has
//                          its own logarithmic rate dependence, a - b).
//   aging                  state-variable aging of the friction level (Dieterich 1979): a contact
//                          age theta [s], theta' = 1 - |v_r| theta / aging_Dc, theta(0) = 0 (a
//                          fresh contact), and F_C, F_S x (1 + aging_beta ln(1 + theta / aging_t0))
//                          aging_beta >= 0 [-], aging_Dc [m] > 0, aging_t0 [s] > 0.
//                          Unlike dwell_time (a stick clock reset when |v_r| passes dwell_v) the
//                          contact heals during creep too, and its memory fades over a slip
//                          distance aging_Dc; in steady sliding theta = aging_Dc / |v|, so the
//                          level 1 + beta ln(1 + D_c / (|v| t0)) also weakens with velocity.
//                          theta is advanced after every accepted integrator step by the exact
//                          solution for |v_r| held at the step's end (first order in the step);
//                          the level is that of the step's start within a step.
//                          Per model as the other level effects (below); rate-and-state and GMS:
//                          no effect.
//
// "Friction level" scaling (waviness, drift, normal load, velocity weakening, aging) multiplies F_C and F_S (Dahl: F_C;
// Karnopp: F_S and F_slip; LuGre: F_C and F_S inside g(v_r), so the bristle relaxes to the new
// level; Reset Integrator: the whole contact force (1 + a) k_t s + beta s', i.e. both the
// sliding force k_t s0 and the breakaway force).
//
// Every effect has a neutral value of its size parameter (sigma2 = 0, delta = 2, A = 0, eps = 0,
// gamma = 0, eta = 0, sensor_tau = 0, c_d = 0, vw_beta = 0, aging_beta = 0) at which it reproduces the base model exactly.

#include <string>
#include <string_view>
#include <vector>

namespace stickslip::engine {

enum class ExtensionKind {
  kNone,
  kViscous,
  kStribeckShape,
  kDwellTime,
  kWaviness,
  kDrift,
  kNormalLoadModulation,
  kSensorDynamics,
  kDriveDamping,
  kVelocityWeakening,
  kAging,
};
/// The catalogue ids: "none", "viscous", "stribeck_shape", "dwell_time", "waviness", "drift",
/// "normal_load_modulation", "sensor_dynamics", "drive_damping", "velocity_weakening",
/// "aging".
const char* to_string(ExtensionKind k) noexcept;
/// Throws InvalidParameter("effect", name, ...) for an unknown id.
ExtensionKind extension_from_string(std::string_view name);
/// The ten catalogue entries (without kNone), in catalogue order.
const std::vector<ExtensionKind>& extension_catalogue();

/// velocity_weakening's floor of the level factor f(v_r) [-].
inline constexpr double kVelocityWeakeningFloor = 0.05;

struct Extension {
  ExtensionKind kind = ExtensionKind::kNone;
  double sigma2 = 0.0;           ///< viscous: [N s/m]
  double stribeck_delta = 2.0;   ///< stribeck_shape: exponent [-]
  double dwell_A = 0.0;          ///< dwell_time: log-growth amplitude [N]
  double dwell_tau = 0.1;        ///< dwell_time: time scale [s]
  double dwell_v = 1.0e-4;       ///< dwell_time: |v_r| above this resets the stick clock [m/s]
  double waviness_eps = 0.0;     ///< waviness: relative amplitude [-]
  double waviness_lambda = 1e-3; ///< waviness: wavelength along the track [m]
  double waviness_phi = 0.0;     ///< waviness: phase [rad]
  double drift_gamma = 0.0;      ///< drift: relative change per metre of sliding [1/m]
  double load_eta = 0.0;         ///< normal_load_modulation: relative amplitude [-]
  double load_phi = 0.0;         ///< normal_load_modulation: phase against the base [rad]
  double sensor_tau = 0.0;       ///< sensor_dynamics: 1/omega_n [s]; 0 = ideal sensor
  double sensor_zeta = 0.7;      ///< sensor_dynamics: damping ratio [-]
  double c_d = 0.0;              ///< drive_damping: drive damping [N s/m]
  double vw_beta = 0.0;          ///< velocity_weakening: log-slope of the level [-], in [0, 0.5)
  double vw_v = 1.0e-3;          ///< velocity_weakening: reference velocity [m/s]
  double aging_beta = 0.0;       ///< aging: log-growth of the level with the contact age [-]
  double aging_Dc = 1.0e-5;      ///< aging: slip distance that renews the contact [m]
  double aging_t0 = 0.01;        ///< aging: age scale of the logarithm [s]

  bool active() const noexcept { return kind != ExtensionKind::kNone; }
  bool operator==(const Extension&) const = default;
  /// Appends "field = value: why" per broken constraint. x_max [m] is the largest sliding
  /// distance of the run (for drift: 1 + gamma x must stay > 0); v_max [m/s] the drive plus the
  /// largest vibration velocity (for velocity_weakening: f(v_max) must stay above its floor
  /// 0.05); pass 0 to skip either check.
  bool IsValid(std::vector<std::string>* errors = nullptr, double x_max = 0.0,
               double v_max = 0.0) const;
};

/// Parameter names of one effect, its size parameter first (e.g. "sigma2"; for dwell_time
/// "dwell_A", "dwell_tau", "dwell_v"). Empty for kNone.
std::vector<std::string> extension_parameter_names(ExtensionKind k);
/// Every extension parameter name (all effects), plus the alias "sensor_omega_n" = 1/sensor_tau.
std::vector<std::string> all_extension_parameter_names();
/// The effect a parameter belongs to; kNone for a name that is not an extension parameter.
ExtensionKind extension_of_parameter(std::string_view name);
/// Sets / reads one extension parameter by name with domain checks (InvalidParameter naming
/// the field and the value). Returns false (and does nothing) when name is not one of them.
bool set_extension_parameter(Extension& e, std::string_view name, double value);
bool get_extension_parameter(const Extension& e, std::string_view name, double* value);

}  // namespace stickslip::engine
