#pragma once
// Generalized Maxwell-Slip friction (Al-Bender F., Lampaert V., Swevers J. (2005) The generalized
// Maxwell-slip model: a novel model for friction simulation and compensation, IEEE Trans. Autom.
// Control 50(11):1883-1887). N elementary Maxwell-slip elements in parallel, each a spring of
// stiffness k_i with a maximum force alpha_i s(v_r), s the Stribeck curve. Internal states: the
// element forces F_i [N], i = 1 .. N (N <= kMaxElements).
//
//   s(v_r) = F_C + (F_S - F_C) exp(-(v_r/v_s)^2)                     (the seed's LuGre curve) [N]
//   element i sticks:  F_i' = k_i v_r,       until sgn(v_r) F_i reaches alpha_i s(v_r)      [N/s]
//   element i slips:   F_i' = C (sgn(v_r) alpha_i - F_i / s(v_r)),  until v_r reverses    [N/s]
//   F_f = sum_i (F_i + sigma_i F_i'/k_i) + h_v v_r,  sigma_i = h_t exp(-(v_r/v_s)^2) k_i / k_t [N]
//
// A slipping element relaxes to its share alpha_i s(v_r) of the Stribeck curve at the rate C [N/s]
// (time constant s/C); the paper writes sgn(v) C (alpha_i - F_i/s), which for v < 0 drives F_i
// away from -alpha_i s: the sign-consistent form above is the one that relaxes to
// sgn(v) alpha_i s(v) in both directions. With sum alpha_i = 1 the presliding force saturates at
// sum alpha_i s(0) = F_S (breakaway) and steady sliding gives s(v) + h_v v. The element damping
// sigma_i F_i'/k_i (the deflection rate times sigma_i) damps the contact's oscillation in stick;
// split in proportion to k_i, the elements together damp like LuGre's bristle: h_t with the
// seed's velocity factor exp(-(v_r/v_s)^2) (eqs. 21-22). Al-Bender et al. take sigma_i constant;
// then, under the seed's 4 mm/s base vibration, every element sticks again after each reversal of
// v_r and the damping force h_t v_r reaches ~20-55 N, several times the friction level, before
// the elements break away again (measured: the mean friction's trapezoid error at rtol 1e-7 was
// 0.0125 N, 0.07 N at 1e-5). Each element's stick/slip switch is a located event (the hybrid form
// below), so the model runs on rk4_event and adaptive (not on plain rk4, whose unlocated form
// would need each element's mode as state); it has no batched kernel.
//
// The N elements in a flat traits table. A presliding curve with few parameters, distributed
// over N elements by a fixed rule, so that N can change without new parameters and the
// diagnosis fits the curve, not 2N numbers. The rule discretises the exponential virgin curve
// F_S (1 - exp(-k_t x / F_S)) of Dahl and LuGre (the seed's other presliding models, same
// k_t and F_S): equal stiffness k_i = k_t/N (total initial stiffness k_t), and breakaway
// deflections at its quantiles, d_i = (F_S/k_t) ln(N / (N - i + 1/2)), i.e. element i slips where
// the curve's slope has fallen to (N - i + 1/2)/N of k_t; alpha_i = k_i d_i / sum_j k_j d_j, so
// sum alpha_i = 1 exactly (the breakaway force is F_S for every N). The virgin curve is then
// piecewise linear through the exponential one; N = 1 is a single Maxwell-slip element (an
// elasto-plastic spring with Stribeck sliding).
#include <array>
#include <cmath>
#include <cstdint>

#include "stickslip/engine/model_api.h"
#include "stickslip/engine/models/contact.h"

namespace stickslip::engine {

struct GmsHybrid;

struct Gms {
  static constexpr int kMaxElements = 12;
  static constexpr ModelInfo kInfo{
      "gms",
      "Generalized Maxwell-Slip",
      "Al-Bender, Lampaert & Swevers 2005",
      ModelClass::kSwitching,
      {"F", kForce, "summed element force"},
      "each element's stick/slip mode is located (rk4_event, adaptive)",
      0x6u,  // rk4_event and adaptive (IntegratorKind 1 and 2)
      false};
  static constexpr ParamDef kParams[] = {
      contact::kFS.with_fit(contact::kFitStaticForce),
      contact::kFC.with_fit(contact::kFitCoulombFraction),
      contact::kVs.with_fit({2e-5, 1e-2, FitScale::kLog}),
      {"C_el", kForceRate, 1e4, kPositive,
       "GMS slip relaxation rate of each element (time constant s(v)/C_el)",
       {1e1, 1e7, FitScale::kLog, [](const FitLevels& l) { return 1e3 * l.slip; }}},
      {"N_el", kDimensionless, 4, {1.0, kMaxElements, false, false, true},
       "GMS number of Maxwell-slip elements"},
      contact::kKt,
      contact::kHt,
      contact::kHv,
  };
  static constexpr Constraint kConstraints[] = {{"F_S", "F_C"}};
  static constexpr int kStates = kMaxElements;

  double k_t, h_t, h_v, F_C, F_S, v_s, C, N;
  double inv_vs2;                          // 1/v_s^2 [s^2/m^2]
  std::array<double, kMaxElements> k{};    // element stiffness k_i [N/m]
  std::array<double, kMaxElements> alpha{};  // element share alpha_i [-]

  explicit Gms(const ModelInputs& in)
      : k_t(in["k_t"]), h_t(in["h_t"]), h_v(in["h_v"]), F_C(in["F_C"]), F_S(in["F_S"]),
        v_s(in["v_s"]), C(in["C_el"]), N(in["N_el"]), inv_vs2(1.0 / (v_s * v_s)) {
    const int n = elements();
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
      const auto ii = static_cast<std::size_t>(i);
      k[ii] = k_t / n;
      const double d = F_S / k_t * std::log(n / (n - i - 0.5));  // breakaway deflection [m]
      alpha[ii] = k[ii] * d;
      sum += alpha[ii];
    }
    for (int i = 0; i < n; ++i) alpha[static_cast<std::size_t>(i)] /= sum;
  }
  int elements() const noexcept { return static_cast<int>(N); }
  /// The internal states that move (the integrators skip the other, zero, element slots).
  int active_states() const noexcept { return elements(); }
  /// The Stribeck factor exp(-(v_r/v_s)^2) [-] (0 where it underflows).
  double stribeck(double v_r) const noexcept {
    const double q = v_r * v_r * inv_vs2;
    return q > 745.0 ? 0.0 : std::exp(-q);
  }
  /// The Stribeck curve s(v_r) [N], from its factor e = stribeck(v_r).
  double s_of(double e) const noexcept { return F_C + (F_S - F_C) * e; }
  double s(double v_r) const noexcept { return s_of(stribeck(v_r)); }
  /// Element i's rate in stick or slip (dir = sgn(v_r) of the slip) [N/s].
  double stick_rate(int i, double v_r) const noexcept {
    return k[static_cast<std::size_t>(i)] * v_r;
  }
  double slip_rate(int i, double dir, double F_i, double s_v) const noexcept {
    return C * (dir * alpha[static_cast<std::size_t>(i)] - F_i / s_v);
  }
  /// The friction force from the element forces and rates [N] (e: stribeck(v_r)).
  template <class Z>
  double friction(const Z& F, const Z& dF, double v_r, double e) const noexcept {
    double sum_F = 0.0, sum_dF = 0.0;
    for (int i = 0; i < elements(); ++i) {
      sum_F += F[static_cast<std::size_t>(i)];
      sum_dF += dF[static_cast<std::size_t>(i)];
    }
    return sum_F + h_t / k_t * e * sum_dF + h_v * v_r;
  }
  /// The primary state: the summed element force [N].
  double primary_state(const std::array<double, kStates>& z) const noexcept {
    double sum = 0.0;
    for (double f : z) sum += f;
    return sum;
  }
  /// x' by the contact impedance sqrt(k_t m), each element force by 1 [N per N].
  ErrorWeights<kStates> error_weights(const Drive& d) const noexcept {
    ErrorWeights<kStates> w{std::sqrt(k_t * d.m), {}};
    w.z.fill(1.0);
    return w;
  }
  std::array<double, kStates> state_scale(double f_ref) const noexcept {
    std::array<double, kStates> s;
    s.fill(f_ref);
    return s;
  }

  using Hybrid = GmsHybrid;
};

/// GMS in hybrid form: the mode holds which elements slip (bit i) and the direction of the slip
/// (all slipping elements slip with v_r, and all stick again when it reverses).
struct GmsHybrid {
  struct Mode {
    std::uint32_t slipping = 0;
    int dir = 0;  ///< sgn(v_r) of the slip (0 when none slips)
  };
  using Model = Gms;
  using State = StateT<Gms::kStates>;
  /// The adaptive integrator's step limiter at reversals of v_r (the element damping's Stribeck
  /// factor exp(-(v_r/v_s)^2) is a bump ~v_s / |v_r'| wide there, ~9 us at 4 mm/s).
  static constexpr bool kReversals = true;
  using Z = std::array<double, Gms::kStates>;
  Gms m;
  GmsHybrid(const Gms& g, const Drive& /*d*/) : m(g) {}

  static bool slips(const Mode& mode, int i) noexcept { return (mode.slipping >> i) & 1u; }

  /// From the state alone: an element slips where it is at (or beyond) its limit, loaded in the
  /// direction of v_r.
  Mode classify(const Point& p, const Z& F) const noexcept {
    Mode mode;
    const double dir = sgn(p.v_r), s_v = m.s(p.v_r);
    if (dir == 0.0) return mode;
    for (int i = 0; i < m.elements(); ++i)
      if (dir * F[static_cast<std::size_t>(i)] >= m.alpha[static_cast<std::size_t>(i)] * s_v *
                                                      (1.0 - 1e-12))
        mode.slipping |= 1u << i;
    mode.dir = mode.slipping ? static_cast<int>(dir) : 0;
    return mode;
  }
  FrictionEvalN<Gms::kStates> eval(const Mode& mode, const Point& p, const Z& F) const noexcept {
    FrictionEvalN<Gms::kStates> fe{0.0, {}};
    const double e = m.stribeck(p.v_r), s_v = m.s_of(e);  // one exp for both
    for (int i = 0; i < m.elements(); ++i) {
      const auto ii = static_cast<std::size_t>(i);
      fe.dz[ii] = slips(mode, i) ? m.slip_rate(i, mode.dir, F[ii], s_v) : m.stick_rate(i, p.v_r);
    }
    fe.F_f = m.friction(F, fe.dz, p.v_r, e);
    return fe;
  }
  /// The smallest event function (>= 0 inside the mode) and the mode it leads to: a sticking
  /// element reaching its limit alpha_i s(v_r) while loaded with v_r; the slipping ones'
  /// direction of v_r reversing.
  double event(const Mode& mode, const Point& p, const Z& F, Mode* next) const noexcept {
    double e = 1e300;
    const double s_v = m.s(p.v_r), dir = sgn(p.v_r);
    if (mode.slipping) {
      e = mode.dir * p.v_r;
      *next = Mode{};
    }
    for (int i = 0; i < m.elements(); ++i) {
      if (slips(mode, i)) continue;
      const auto ii = static_cast<std::size_t>(i);
      const double load = dir * F[ii];
      const double ei = load > 0.0 ? m.alpha[ii] * s_v - load : m.alpha[ii] * s_v + std::fabs(F[ii]);
      if (ei < e) {
        e = ei;
        *next = Mode{mode.slipping | (1u << i), static_cast<int>(dir)};
        if (mode.slipping && mode.dir != static_cast<int>(dir)) next->slipping = 1u << i;
      }
    }
    return e;
  }
  Mode settle(const Mode& /*from*/, const Mode& to, const Point& /*p*/) const noexcept {
    return to;
  }
  /// An element that starts to slip sits exactly at its limit (no round-off re-firing).
  void on_enter(const Mode& mode, const Point& p, State& y, const Mode& from) const noexcept {
    const std::uint32_t started = mode.slipping & ~from.slipping;
    if (!started) return;
    const double s_v = m.s(p.v_r);
    for (int i = 0; i < m.elements(); ++i)
      if ((started >> i) & 1u)
        internal(y, i) = mode.dir * m.alpha[static_cast<std::size_t>(i)] * s_v;
  }
};

}  // namespace stickslip::engine
