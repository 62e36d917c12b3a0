// The Generalized Maxwell-Slip model's physics (models/gms.h; Al-Bender, Lampaert & Swevers
// 2005): the element rule (shares summing to 1, total stiffness k_t), presliding hysteresis with
// non-local memory (inner loops close on the outer curve and the outer curve continues as if
// they had not happened), the breakaway force sum alpha_i s(0) = F_S, the sliding force s(v) at
// steady velocity, and the seed's runs with up to 12 elements. The shared checks are in
// test_models.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "stickslip/engine/simulate.h"

using namespace stickslip::engine;

namespace {

SimConfig config(int n = 4) {
  SimConfig c = SimConfig::seed(model_kind<Gms>, 0.0);
  set_parameter(c, "N_el", n);
  return c;
}

/// The contact driven kinematically through the relative displacement path `xs` (piecewise
/// linear, at |v_r| = v), its element forces advanced through the model's hybrid form: the mode
/// from the state (classify), the elements' rates (eval), and a sticking element that passes its
/// limit within a step entering slip at the limit (event, on_enter), as the integrators do at a
/// located switch. Returns the summed element force (the friction force less its damping terms,
/// which vanish quasi-statically) at every step end and the displacement there.
struct Path {
  std::vector<double> x, F;
};
Path drive(const Gms& g, const std::vector<double>& xs, double v, int steps_per_leg) {
  const GmsHybrid hyb(g, Drive{});
  GmsHybrid::State y{};
  Path out{{xs[0]}, {0.0}};
  double x = xs[0];
  for (std::size_t leg = 1; leg < xs.size(); ++leg) {
    const double dir = xs[leg] > xs[leg - 1] ? 1.0 : -1.0;
    const double dx = (xs[leg] - xs[leg - 1]) / steps_per_leg, dt = std::fabs(dx) / v;
    for (int k = 0; k < steps_per_leg; ++k) {
      const Point p{0.0, dir * v};
      const GmsHybrid::Mode mode = hyb.classify(p, internal_states(y));
      const auto fe = hyb.eval(mode, p, internal_states(y));
      for (int i = 0; i < Gms::kStates; ++i) internal(y, i) += dt * fe.dz[static_cast<std::size_t>(i)];
      GmsHybrid::Mode next;
      if (hyb.event(mode, p, internal_states(y), &next) < 0.0) hyb.on_enter(next, p, y, mode);
      x += dx;
      out.x.push_back(x);
      out.F.push_back(g.primary_state(internal_states(y)));  // (no damping: quasi-static)
    }
  }
  return out;
}

}  // namespace

// The element rule: shares alpha_i sum to 1 and the stiffnesses to k_t for every N; the breakaway
// deflections grow with i (the virgin curve is concave); unused elements are zero.
TEST(Gms, ElementsShareTheCurve) {
  for (int n = 1; n <= Gms::kMaxElements; ++n) {
    const Gms g = make_model<Gms>(config(n));
    double sa = 0, sk = 0, last_d = 0;
    for (int i = 0; i < n; ++i) {
      const auto ii = static_cast<std::size_t>(i);
      sa += g.alpha[ii];
      sk += g.k[ii];
      const double d = g.alpha[ii] * g.F_S / g.k[ii];  // breakaway deflection [m]
      EXPECT_GT(d, last_d);
      last_d = d;
    }
    EXPECT_NEAR(sa, 1.0, 1e-14) << n;
    EXPECT_NEAR(sk, g.k_t, 1e-6 * g.k_t) << n;
    for (int i = n; i < Gms::kMaxElements; ++i) EXPECT_EQ(g.alpha[static_cast<std::size_t>(i)], 0.0);
  }
  SimConfig c = config();
  EXPECT_THROW(set_parameter(c, "N_el", 13), InvalidParameter);
  EXPECT_THROW(set_parameter(c, "N_el", 2.5), InvalidParameter);
}

// Presliding hysteresis with non-local memory (Al-Bender et al. 2005, Fig. 2): between +-A (A =
// 1.5 F_S/k_t, some elements slip) the force-displacement curve is a hysteresis loop; an inner
// loop from +A down to +A - 2B and back closes where it started, and the descent then follows the
// outer loop's descending branch as if the inner loop had not happened (wiping out). Quasi-static
// (|v_r| = 1 um/s, s(v) = F_S).
TEST(Gms, PreslidingHysteresisWithNonLocalMemory) {
  const Gms g = make_model<Gms>(config(6));
  const double x0 = g.F_S / g.k_t, A = 1.5 * x0, B = 0.4 * x0, v = 1e-6;
  const int n = 3000;
  // virgin 0 -> A, outer loop A -> -A -> A, then the outer descent A -> -A
  const Path outer = drive(g, {0, A, -A, A, -A}, v, n);
  // the same with an inner loop A -> A - 2B -> A before the last descent
  const Path inner = drive(g, {0, A, -A, A, A - 2 * B, A, -A}, v, n);
  const double F_top = outer.F[3 * n];  // at +A before the last descent
  EXPECT_NEAR(inner.F[3 * n], F_top, 1e-12);
  EXPECT_NEAR(inner.F[5 * n], F_top, 1e-9 * g.F_S) << "the inner loop closes on the outer curve";
  double worst = 0.0;  // the descents after +A: inner path legs 6, outer path leg 4
  for (int k = 0; k <= n; ++k)
    worst = std::max(worst, std::fabs(inner.F[5 * n + k] - outer.F[3 * n + k]));
  EXPECT_LT(worst, 1e-9 * g.F_S) << "the descent continues on the outer branch";
  // a hysteresis loop: ascending and descending branches differ at x = 0
  const double F_up0 = outer.F[2 * n + n / 2], F_down0 = outer.F[n + n / 2];
  EXPECT_GT(F_up0 - F_down0, 0.5);
  // the inner loop is a loop too: its descending and ascending legs differ in the middle
  const double F_in_down = inner.F[3 * n + n / 2], F_in_up = inner.F[4 * n + n / 2];
  EXPECT_GT(F_in_up - F_in_down, 0.05);
  // and below the largest reversal force everything is elastic on the virgin curve
  EXPECT_NEAR(outer.F[n / 100], g.k_t * outer.x[n / 100], 1e-9 * g.F_S);
  std::printf("presliding: F(+A) %.4f N, outer loop width at x = 0 %.4f N, inner loop width "
              "%.4f N, inner/outer mismatch after the inner loop %.2g N\n",
              F_top, F_up0 - F_down0, F_in_up - F_in_down, worst);
}

// The breakaway force: loaded far beyond every element's deflection, the friction saturates at
// sum alpha_i s(0) = F_S (slow loading, s(1 um/s) = F_S to 1e-5); and the seed's still-base run
// breaks away at F_S (the first peak of F_d, within the dynamics' overshoot of 1 %).
TEST(Gms, BreakawayForceIsSumOfShares) {
  for (int n : {1, 4, 12}) {
    const Gms g = make_model<Gms>(config(n));
    const double x0 = g.F_S / g.k_t;
    const Path p = drive(g, {0, 10 * x0}, 1e-6, 4000);
    double shares = 0;
    for (int i = 0; i < n; ++i) shares += g.alpha[static_cast<std::size_t>(i)] * g.s(1e-6);
    EXPECT_NEAR(p.F.back(), shares, 1e-9) << n;
    EXPECT_NEAR(p.F.back(), g.F_S, 1e-4 * g.F_S) << n;
  }
  SimConfig c = config();
  c.stages = {Stage{1.5, 0.0, 1500.0}};
  c.trace.rate = 1e5;
  const SimResult r = simulate(c);
  ASSERT_EQ(r.status, RunStatus::kOk) << r.reason;
  double peak = 0;
  for (const TraceSample& s : r.trace) {
    if (s.F_d < peak - 1.0) break;  // the first slip
    peak = std::max(peak, s.F_d);
  }
  std::printf("first breakaway in the seed's run: peak F_d %.4f N (F_S = 11.1 N)\n", peak);
  EXPECT_NEAR(peak, 11.1, 0.01 * 11.1);
}

// The sliding force at steady velocity is s(v) (+ h_v v): every element slips and relaxes to its
// share alpha_i s(v); kinematically at several velocities, and in the engine with a stiff drive
// at 10 mm/s (the Stribeck curve weakens with velocity: a soft drive would stick and slip).
TEST(Gms, SlidingForceIsTheStribeckCurve) {
  const Gms g = make_model<Gms>(config(5));
  const double x0 = g.F_S / g.k_t;
  for (double v : {1e-5, 3.5e-4, 1e-3, 1e-2}) {
    const Path p = drive(g, {0, 20 * x0 + 20 * v * g.s(v) / g.C}, v, 20000);
    EXPECT_NEAR(p.F.back(), g.s(v), 1e-6 * g.F_S) << v;
  }
  SimConfig c = config(5);
  c.drive.v_d = 1e-2;
  c.drive.k_d = 1e7;
  set_parameter(c, "h_v", 400.0);  // damping ratio 0.08 with the drive spring
  c.stages = {Stage{0.2, 0.0, 1500.0}};
  const SimResult r = simulate(c);
  ASSERT_EQ(r.status, RunStatus::kOk) << r.reason;
  const double expected = g.s(1e-2) + 400.0 * 1e-2;
  std::printf("steady sliding at 10 mm/s: mean friction %.5f N, s(v) + h_v v = %.5f N\n",
              r.stages[0].mean_friction, expected);
  EXPECT_NEAR(r.stages[0].mean_friction, expected, 1e-3);
  EXPECT_LT(r.stages[0].amplitude_raw, 1e-3) << "steady";
}

// The seed's two-stage run with the largest element count completes and sticks and slips on the
// still base like the single-element model's breakaway suggests (amplitude about F_S - s(v_slip)).
TEST(Gms, SeedRunWithTwelveElements) {
  for (int n : {1, 12}) {
    SimConfig c = config(n);
    c.stages = {Stage{4.0, 0.0, 1500.0}, Stage{1.0, 4e-3, 1500.0}};
    const SimResult r = simulate(c);
    ASSERT_EQ(r.status, RunStatus::kOk) << n << ": " << r.reason;
    std::printf("N = %d: still-base amplitude %.4f N (%d slips), 4 mm/s mean F_d %.4f N, "
                "%zu steps, %zu switches\n",
                n, r.stages[0].amplitude, r.stages[0].slip_events, r.stages[1].mean_force,
                r.steps, r.switches);
    EXPECT_GT(r.stages[0].amplitude, 3.0);
    EXPECT_LT(r.stages[1].mean_force, 0.5 * r.stages[0].mean_force) << "vibration lowers it";
  }
}

// Each element's stick/slip mode carries over a stage boundary and a checkpoint. With one
// element (its force is the trace's s) and a slow relaxation C_el, the element slips below its
// limit while |v_r| falls and the Stribeck curve rises. A still-base run split into two stages
// there equals the one-stage run to the integration tolerance (a split that restarted the element
// as sticking would load it at k_t v_r up to its limit at once); and the split run continued from
// a checkpoint at the boundary is bitwise the split run from rest.
TEST(Gms, SlipBelowItsLimitContinuesAcrossStagesAndCheckpoints) {
  SimConfig c = config(1);
  set_parameter(c, "C_el", 100.0);
  c.integrator.rtol = 1e-10;
  c.stages = {Stage{1.5, 0.0, 1500.0}};
  c.trace.rate = 1e5;
  const Gms g = make_model<Gms>(c);
  const SimResult whole = simulate(c);
  ASSERT_EQ(whole.status, RunStatus::kOk) << whole.reason;
  // The split: of the samples where the element's force moves at its slip rate C (sgn(v) - F/s(v))
  // (not at its stick rate k_t v), more than 2 % below its limit s(v), with |v| falling (the base
  // is still: v_r = v), the one with the largest |v| (a sticking element would close the gap
  // fastest there).
  double t_split = 0.0, gap = 0.0, v_split = 0.0;
  const auto& tr = whole.trace;
  for (std::size_t i = 1; i + 1 < tr.size(); ++i) {
    const double v = tr[i].v, dir = v > 0 ? 1.0 : -1.0, F = tr[i].s, s_v = g.s(v);
    if (std::fabs(v) < 1e-5 || tr[i + 1].t <= tr[i].t) continue;
    const double rate = (tr[i + 1].s - F) / (tr[i + 1].t - tr[i].t);
    const double slip = g.slip_rate(0, dir, F, s_v), stick = g.stick_rate(0, v);
    const bool slipping = std::fabs(rate - slip) < 0.05 * std::fabs(stick - slip);
    if (slipping && 1.0 - dir * F / s_v > 0.02 && std::fabs(v) > v_split &&
        std::fabs(tr[i + 1].v) < std::fabs(v)) {
      t_split = tr[i].t;
      v_split = std::fabs(v);
      gap = 1.0 - dir * F / s_v;
    }
  }
  ASSERT_GT(t_split, 0.0) << "no slip 2 % below the limit with |v| falling in the run";
  SimConfig split = c;
  split.stages = {Stage{t_split, 0.0, 1500.0}, Stage{0.3, 0.0, 1500.0}};
  SimConfig shorter = c;
  shorter.stages = {Stage{t_split + 0.3, 0.0, 1500.0}};
  const SimResult a = simulate(shorter), b = simulate(split);
  ASSERT_EQ(a.status, RunStatus::kOk) << a.reason;
  ASSERT_EQ(b.status, RunStatus::kOk) << b.reason;
  double worst = 0.0;  // F_d of the two runs at the same times after the split [N]
  std::size_t j = 0, compared = 0;
  for (const TraceSample& s : b.trace) {
    if (s.t <= t_split) continue;
    while (j < a.trace.size() && a.trace[j].t < s.t) ++j;
    if (j == a.trace.size()) break;
    if (a.trace[j].t != s.t) continue;
    worst = std::max(worst, std::fabs(a.trace[j].F_d - s.F_d));
    ++compared;
  }
  std::printf("split at %.6f s (v %.3g m/s), the element %.1f %% below its limit: F_d after the split within "
              "%.3g N of the one-stage run (%zu samples), x_end %.3g m apart\n",
              t_split, v_split, 100 * gap, worst, compared, std::fabs(a.x_end - b.x_end));
  EXPECT_GT(compared, 1000u);
  EXPECT_LT(worst, 1e-4) << "restarted as sticking: ~4e-3 N";
  SimCheckpoint cp;
  const SimResult first = simulate(split, 1, &cp);
  ASSERT_EQ(cp.stages(), 1u);
  const SimResult resumed = simulate_from(split, cp);
  ASSERT_EQ(resumed.status, RunStatus::kOk) << resumed.reason;
  EXPECT_EQ(resumed.x_end, b.x_end);
  EXPECT_EQ(resumed.v_end, b.v_end);
  EXPECT_EQ(resumed.s_end, b.s_end);
  ASSERT_EQ(resumed.trace.size(), b.trace.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < b.trace.size(); ++i)
    differ += resumed.trace[i].F_d != b.trace[i].F_d || resumed.trace[i].s != b.trace[i].s;
  EXPECT_EQ(differ, 0u);
}
