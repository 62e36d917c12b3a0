// Why the normal_load_modulation candidate is fitted in the components eta_v = eta sin(phi)
// and eta_q = eta cos(phi) (diagnosis/include/stickslip/diagnosis/detail/diagnose_load.h): below the vibration frequency F_d
// shows only the mean level of a vibrating stage, linear in (eta_v, eta_q), mostly through
// eta_v. Engine checks on the hidden-effect suite's LuGre parameters, and the delta method of
// the derived (eta, phi).
#include <gtest/gtest.h>

#include <cmath>

#include "stickslip/diagnosis/detail/diagnose_load.h"
#include "stickslip/engine/simulate.h"

namespace {

using namespace stickslip;

/// Mean F_d [N] over the vibrating stage (after 0.2 s of settling), LuGre as in the suite.
double vibrating_level(double va, double eta, double phi) {
  engine::SimConfig c = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, va);
  c.friction["F_S"] = 11.1 * 1.06;
  c.friction["F_C"] = 8.3 * 0.95;
  c.friction["v_s"] = 3.5e-4 * 0.92;
  c.stages = {engine::Stage{3.0, 0.0, 1500}, engine::Stage{1.5, va, 1500}};  // the CI datasets
  if (eta > 0) {
    c.extension.kind = engine::ExtensionKind::kNormalLoadModulation;
    c.extension.load_eta = eta;
    c.extension.load_phi = phi;
  }
  c.integrator.kind = engine::IntegratorKind::kAdaptive;
  c.integrator.rtol = c.integrator.atol = 1e-8;
  c.trace.rate = 4000;
  const engine::SimResult r = engine::simulate(c);
  EXPECT_EQ(r.status, engine::RunStatus::kOk) << r.reason;
  double sum = 0;
  int n = 0;
  for (const auto& s : r.trace)
    if (s.t > 3.2) {
      sum += s.F_d;
      ++n;
    }
  return n ? sum / n : NAN;
}

}  // namespace

TEST(DiagnoseLoadPhysics, StageLevelIsLinearInTheComponentsAndMostlySeesTheInPhaseOne) {
  const double eta = 0.1, F_C = 8.3 * 0.95, v_d = 1e-3;
  double quad[2];
  const double vas[2] = {1.5e-3, 5e-3};
  for (int i = 0; i < 2; ++i) {
    const double va = vas[i];
    const double base = vibrating_level(va, 0, 0);
    const double up = vibrating_level(va, eta, M_PI / 2) - base;  // eta_v = +eta
    const double dn = vibrating_level(va, eta, -M_PI / 2) - base; // eta_v = -eta
    const double q0 = vibrating_level(va, eta, 0.0) - base;       // eta_q = +eta
    const double qp = vibrating_level(va, eta, M_PI) - base;      // eta_q = -eta
    const double a = (up - dn) / (2 * eta), b = (q0 - qp) / (2 * eta);  // [N per unit]
    quad[i] = b;
    // Rigid Coulomb friction, v_a > v_d: dF/d eta_v = -F_C (2/pi) sqrt(1 - (v_d/v_a)^2). LuGre's
    // bristles reduce it at small v_a (1.5 mm/s: -1.9 N against -3.7 N), not at 5 mm/s.
    const double rigid = -F_C * (2 / M_PI) * std::sqrt(1 - (v_d / va) * (v_d / va));
    EXPECT_LT(a, 0) << va;
    EXPECT_GT(a, 1.1 * rigid) << va;
    if (va > 4e-3) {
      EXPECT_NEAR(a, rigid, 0.05 * std::fabs(rigid));
    }
    // The quadrature part leaves a trace 5-7 times weaker (zero for rigid Coulomb friction).
    EXPECT_LT(std::fabs(b), 0.25 * std::fabs(a)) << va;
    EXPECT_GT(std::fabs(b), 0.05 * std::fabs(a)) << va;
    // Nearly linear in the components: phi = 1 rad is predicted from the four shifts within
    // 12 % (measured: 9 % at 1.5 mm/s, where the even second-order part is largest).
    const double at1 = vibrating_level(va, eta, 1.0) - base;
    const double pred = a * eta * std::sin(1.0) + b * eta * std::cos(1.0);
    EXPECT_NEAR(at1, pred, 0.12 * std::fabs(pred)) << va;
  }
  // Its sign changes with v_a, which is what makes eta_q identifiable from two runs at all.
  EXPECT_LT(quad[0] * quad[1], 0);
}

TEST(DiagnoseLoad, DerivedEtaAndPhiFollowTheDeltaMethod) {
  using stickslip::diagnosis::detail::derived_load_estimates;
  // eta_v = 0.3, eta_q = 0.4: eta = 0.5, phi = atan2(0.3, 0.4); independent errors 0.01, 0.02.
  const auto e = derived_load_estimates(0.3, 0.4, {1e-4, 0.0, 0.0, 4e-4});
  ASSERT_EQ(e.size(), 2u);
  EXPECT_EQ(e[0].name, "load_eta");
  EXPECT_NEAR(e[0].value, 0.5, 1e-12);
  EXPECT_NEAR(e[1].value, std::atan2(0.3, 0.4), 1e-12);
  // d eta = 0.6 d eta_v + 0.8 d eta_q; d phi = (0.4 d eta_v - 0.3 d eta_q) / 0.25.
  EXPECT_NEAR(e[0].stderr_, std::sqrt(0.36e-4 + 0.64 * 4e-4), 1e-12);
  EXPECT_NEAR(e[1].stderr_, std::sqrt(0.16e-4 + 0.09 * 4e-4) / 0.25, 1e-12);
  // No covariance: NaN errors, values still reported.
  const auto n = derived_load_estimates(0.3, 0.4, {});
  EXPECT_TRUE(std::isnan(n[0].stderr_));
  EXPECT_NEAR(n[0].value, 0.5, 1e-12);
}
