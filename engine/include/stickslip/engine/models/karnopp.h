#pragma once
// Karnopp (the seed's eq. 11; Karnopp D. (1985) Computer simulation of stick-slip friction in
// mechanical dynamic systems, J. Dyn. Syst. Meas. Control 107:100-103). No internal state.
//
//   |v_r| <= DV : F_f = sat(F_d, F_S) = clamp(F_d, -F_S, F_S)     (stick)            [N]
//   |v_r| >  DV : F_f = F_slip sgn(v_r)                             (slip; F_slip = F_C)
//
// The seed prints min(|F_d|, F_S) sgn(v_r) in the stick band. Inside the band v_r is "zero" and
// its sign is noise: with sgn(v_r) a body creeping backwards by 1e-6 m/s would be pushed forward by
// friction, i.e. friction would do positive work. Static friction reacts to the applied force,
// so the physical sign is that of F_d: then m x'' = F_d - F_f = 0 while |F_d| <= F_S, which is
// what "stick" means.
#include <cmath>

#include "stickslip/engine/model_api.h"
#include "stickslip/engine/models/contact.h"

namespace stickslip::engine {

struct KarnoppHybrid;

struct Karnopp {
  static constexpr ModelInfo kInfo{"karnopp", "Karnopp", "Rybkiewicz & Leus eq. 11; Karnopp 1985",
                                   ModelClass::kSwitching, {"s", kLength, "unused (always 0)"}};
  static constexpr ParamDef kParams[] = {
      contact::kFS.with_fit(contact::kFitStaticForce),
      contact::kFC.with_fit(contact::kFitCoulombFraction),
      {"DV", kVelocity, 1.0e-5, kPositive, "Karnopp zero-velocity band half-width"},
  };
  static constexpr Constraint kConstraints[] = {{"F_S", "F_C"}};
  static constexpr int kStates = 0;
  /// One of the seed's four models: every study spec's canonical form carries its parameters
  /// (registry.h, ModelTraits::in_every_canonical_spec).
  static constexpr bool kInEveryCanonicalSpec = true;

  double DV, F_S, F_slip;

  explicit Karnopp(const ModelInputs& in) : DV(in["DV"]), F_S(in["F_S"]), F_slip(in["F_C"]) {}

  // Written with selects, not branches, so that the batched kernels vectorise it. Equal to
  // sat(F_d, F_S) in the band and F_slip sgn(v_r) outside (v_r != 0 there since DV > 0).
  FrictionEval operator()(double v_r, double /*s*/, double F_d) const noexcept {
    const double stick = F_d > F_S ? F_S : (F_d < -F_S ? -F_S : F_d);
    const double slip = std::copysign(F_slip, v_r);
    return {std::fabs(v_r) <= DV ? stick : slip, 0.0};
  }
  /// x' by the drive impedance sqrt(k_d m) (no contact stiffness).
  ErrorWeights<0> error_weights(const Drive& d) const noexcept {
    return {std::sqrt(d.k_d * d.m), {}};
  }
  std::array<double, 0> state_scale(double /*f_ref*/) const noexcept { return {}; }

  /// With a catalogue effect: F_S and F_slip scaled by the level, F_S raised by dFS, and sigma2
  /// |v_r| added to the slip branch (stick is a reaction force).
  FrictionEval eval_ext(const EffectTerms& r, const Mod& m, double v_r, double /*s*/,
                        double F_d) const noexcept {
    const double F_s = m.level * (F_S + m.dFS);
    if (std::fabs(v_r) <= DV) return {std::fmin(std::fmax(F_d, -F_s), F_s), 0.0};
    return {(m.level * F_slip + r.sigma2 * std::fabs(v_r)) * sgn(v_r), 0.0};
  }

  using Hybrid = KarnoppHybrid;
};

/// Karnopp in hybrid form, for the event-locating integrators. Besides slip (|v_r| > DV) and the
/// band (stick, or saturated stick when |F_d| > F_S), a vibrating base creates sliding motion ON
/// a band edge v_r = +-DV: the slip side pushes v_r back into the band while the band side (where
/// the body does not accelerate but the base does) pushes it out. Filippov's convention then
/// keeps v_r = +-DV, i.e. the body is carried by the base, with F_f = F_d - m u''. A fixed-step
/// integration of eq. (11) approximates the same motion by chattering across the edge every step.
struct KarnoppHybrid {
  enum class Mode { kSlipPos, kSlipNeg, kStick, kSatPos, kSatNeg, kEdgePos, kEdgeNeg };
  using Model = Karnopp;
  using State = StateT<Model::kStates>;
  Karnopp m;
  double mass;  ///< body mass [kg]
  KarnoppHybrid(const Karnopp& k, const Drive& d) : m(k), mass(d.m) {}

  Mode classify(const Point& p, double /*s*/) const noexcept {
    if (p.v_r > m.DV) return Mode::kSlipPos;
    if (p.v_r < -m.DV) return Mode::kSlipNeg;
    return band_mode(p);
  }
  /// Static and slip friction at this point (the Table 1 values unless an effect modulates them;
  /// slip friction includes the viscous effect's sigma2 |v_r|) [N].
  double FS(const Point& p) const noexcept { return p.mod.level * (m.F_S + p.mod.dFS); }
  double Fslip(const Point& p) const noexcept {
    return p.mod.level * m.F_slip + p.sigma2 * std::fabs(p.v_r);
  }
  Mode band_mode(const Point& p) const noexcept {
    const double F_S = FS(p);
    if (p.F_d > F_S) return Mode::kSatPos;
    if (p.F_d < -F_S) return Mode::kSatNeg;
    return Mode::kStick;
  }
  /// Body acceleration inside the band [m/s^2].
  double band_accel(const Point& p) const noexcept {
    const double F_S = FS(p);
    return (p.F_d - std::fmin(std::fmax(p.F_d, -F_S), F_S)) / mass;
  }
  FrictionEval eval(Mode mode, const Point& p, double /*s*/) const noexcept {
    switch (mode) {
      case Mode::kSlipPos: return {Fslip(p), 0.0};
      case Mode::kSlipNeg: return {-Fslip(p), 0.0};
      case Mode::kStick: return {p.F_d, 0.0};
      case Mode::kSatPos: return {FS(p), 0.0};
      case Mode::kSatNeg: return {-FS(p), 0.0};
      case Mode::kEdgePos:
      case Mode::kEdgeNeg: return {p.F_d - mass * p.a_b, 0.0};
    }
    return {0.0, 0.0};
  }
  /// Smallest event function of the mode (>= 0 inside, fires when < 0), and the mode it leads to.
  double event(Mode mode, const Point& p, double /*s*/, Mode* next) const noexcept {
    const double up = m.DV - p.v_r;     // leaves the band upwards when < 0
    const double down = p.v_r + m.DV;  // leaves the band downwards when < 0
    const double F_S = FS(p), F_slip = Fslip(p);
    double e = 1e300;
    auto take = [&](double value, Mode to) {
      if (value < e) {
        e = value;
        *next = to;
      }
    };
    switch (mode) {
      case Mode::kSlipPos: take(-up, Mode::kStick); break;    // v_r falls to DV
      case Mode::kSlipNeg: take(-down, Mode::kStick); break;  // v_r rises to -DV
      case Mode::kStick:
        take(F_S - p.F_d, Mode::kSatPos);
        take(p.F_d + F_S, Mode::kSatNeg);
        take(up, Mode::kSlipPos);
        take(down, Mode::kSlipNeg);
        break;
      case Mode::kSatPos:
        take(p.F_d - F_S, Mode::kStick);
        take(up, Mode::kSlipPos);
        take(down, Mode::kSlipNeg);
        break;
      case Mode::kSatNeg:
        take(-F_S - p.F_d, Mode::kStick);
        take(up, Mode::kSlipPos);
        take(down, Mode::kSlipNeg);
        break;
      case Mode::kEdgePos:  // needs band side pushing up and slip side pushing down
        take(band_accel(p) - p.a_b, Mode::kStick);
        take(p.a_b - (p.F_d - F_slip) / mass, Mode::kSlipPos);
        break;
      case Mode::kEdgeNeg:
        take(p.a_b - band_accel(p), Mode::kStick);
        take((p.F_d + F_slip) / mass - p.a_b, Mode::kSlipNeg);
        break;
    }
    return e;
  }
  /// The mode actually entered when an event of mode 'from' asks for 'to' at point p.
  Mode settle(Mode from, Mode to, const Point& p) const noexcept {
    const double band_flow = band_accel(p) - p.a_b;  // dv_r/dt inside the band
    switch (to) {
      case Mode::kStick:
      case Mode::kSatPos:
      case Mode::kSatNeg:
        if (from == Mode::kSlipPos && band_flow > 0) return Mode::kEdgePos;
        if (from == Mode::kSlipNeg && band_flow < 0) return Mode::kEdgeNeg;
        return band_mode(p);
      case Mode::kSlipPos: {  // at v_r = +DV, leaving the band or an edge upwards
        if ((p.F_d - Fslip(p)) / mass - p.a_b >= 0) return to;  // slip side moves away
        if (from != Mode::kEdgePos && band_flow > 0) return Mode::kEdgePos;
        return band_mode(p);  // both sides flow back into the band
      }
      case Mode::kSlipNeg: {
        if ((p.F_d + Fslip(p)) / mass - p.a_b <= 0) return to;
        if (from != Mode::kEdgeNeg && band_flow < 0) return Mode::kEdgeNeg;
        return band_mode(p);
      }
      default: return to;
    }
  }
  /// Projects the state onto the entered mode's set: on an edge v_r = +-DV exactly, inside the
  /// band |v_r| <= DV. Without this, round-off drift of 1e-11 m/s past an edge makes the band's
  /// exit event fire at once, and the integrator ping-pongs between modes at zero step length.
  ///
  /// A slip that ends in the band (from kSlipPos/kSlipNeg) ends exactly on its edge: the
  /// located point is up to the locator's tolerance past the event v_r = +-DV, and the body
  /// then creeps through the whole stick at that velocity. The creep velocity's shortfall eps
  /// below DV delays the next breakaway by sqrt(2 m eps / (k_d v_d)) (the band must be crossed
  /// by the saturated acceleration first): eps = 4e-14 m/s (a 1e-14 s tolerance at 4 m/s^2)
  /// gave a 7e-8 s late slip and 1.5e-6 N of F_d offset per stick-slip cycle. The edge is
  /// entered 1e-12 DV inside: exactly on it, the round-off of v_r = x' - u' (~1e-21 m/s) made
  /// the band's exit event fire at once under vibration (4757 zero-length switch loops in 6 s
  /// at 4 mm/s, each ending in a step taken without location: 0.03 N momentum imbalance).
  static constexpr double kEdgeInside = 1.0 - 1e-12;
  void on_enter(Mode mode, const Point& p, State& y, Mode from) const noexcept {
    double target = p.v_r;
    if (mode == Mode::kEdgePos) target = m.DV;
    else if (mode == Mode::kEdgeNeg) target = -m.DV;
    else if (mode == Mode::kStick || mode == Mode::kSatPos || mode == Mode::kSatNeg) {
      target = std::fmin(std::fmax(p.v_r, -m.DV), m.DV);
      if (from == Mode::kSlipPos) target = kEdgeInside * m.DV;
      if (from == Mode::kSlipNeg) target = -kEdgeInside * m.DV;
    }
    y.v += target - p.v_r;
  }
};

}  // namespace stickslip::engine
