// The seed's Figs. 6-9 narrative, as reproduced by an independent fixed-step RK4 implementation
// (dt = 1e-6 s, judged over the last 60 % of each stage). Our engine runs all 16 cases with the
// adaptive integrator. Tolerances and the places we disagree are recorded in docs/engine.md.
#include <gtest/gtest.h>

#include <map>

#include "stickslip/engine/simulate.h"

using namespace stickslip::engine;

namespace {
const SimResult& run(ModelKind m, double v_a_mm_s) {
  static std::map<std::pair<int, int>, SimResult> cache;  // test-local memo, one thread
  const auto key = std::make_pair(static_cast<int>(m), static_cast<int>(v_a_mm_s * 10 + 0.5));
  auto it = cache.find(key);
  if (it == cache.end()) {
    it = cache.emplace(key, simulate(SimConfig::seed(m, v_a_mm_s * 1e-3))).first;
    EXPECT_EQ(it->second.status, RunStatus::kOk) << it->second.reason;
  }
  return it->second;
}
const StageMetrics& still(ModelKind m) { return run(m, 0.0).stages.at(0); }
const StageMetrics& vib(ModelKind m, double v_a) { return run(m, v_a).stages.at(1); }
constexpr auto kDahl = model_kind<Dahl>;
constexpr auto kKarnopp = model_kind<Karnopp>;
constexpr auto kReset = model_kind<ResetIntegrator>;
constexpr auto kLuGre = model_kind<LuGre>;
}  // namespace

TEST(SeedNarrative, Fig6StillBase) {
  EXPECT_LT(still(kDahl).amplitude_raw, 0.5);
  EXPECT_EQ(still(kDahl).slip_events, 0);
  EXPECT_NEAR(still(kKarnopp).amplitude, 5.6, 0.1);
  EXPECT_NEAR(still(kReset).amplitude, 5.3, 0.1);
  EXPECT_NEAR(still(kLuGre).amplitude, 5.55, 0.1);
  for (auto m : {kKarnopp, kReset, kLuGre}) EXPECT_GE(still(m).slip_events, 10);
}

TEST(SeedNarrative, Fig7PartialReductionAt02) {
  EXPECT_LT(vib(kKarnopp, 0.2).amplitude_raw, 0.5) << "Karnopp almost eliminated";
  EXPECT_NEAR(vib(kReset, 0.2).amplitude, 1.3, 0.2) << "Reset Integrator partial";
  EXPECT_NEAR(vib(kLuGre, 0.2).amplitude_raw, 2.5, 0.3) << "LuGre partial";
  EXPECT_GT(vib(kLuGre, 0.2).amplitude, 1.8);
  EXPECT_LT(vib(kLuGre, 0.2).amplitude, still(kLuGre).amplitude / 2);
  EXPECT_NEAR(vib(kDahl, 0.2).mean_force, 8.3, 0.05) << "Dahl mean unchanged";
}

TEST(SeedNarrative, Fig8EliminationAt11) {
  EXPECT_LT(vib(kKarnopp, 1.1).amplitude_raw, 0.3);
  EXPECT_LT(vib(kLuGre, 1.1).amplitude_raw, 0.3);
  EXPECT_NEAR(vib(kDahl, 1.1).mean_force, 5.7, 0.15);
  // Finding (docs/engine.md): the Reset Integrator keeps a ~1 N stick-slip at 1.1 mm/s,
  // against the seed's wording of total elimination for v_a >= v_d.
  EXPECT_GT(vib(kReset, 1.1).amplitude, 0.5);
}

TEST(SeedNarrative, Fig9ForceReductionAt4) {
  EXPECT_NEAR(vib(kDahl, 4).mean_force, 1.32, 0.04);
  EXPECT_NEAR(vib(kKarnopp, 4).mean_force, 1.58, 0.04);
  EXPECT_GE(vib(kReset, 4).mean_force, 1.35);
  EXPECT_LE(vib(kReset, 4).mean_force, 1.75);
  EXPECT_NEAR(vib(kLuGre, 4).mean_force, 1.32, 0.04);
  for (auto m : {kDahl, kKarnopp, kReset, kLuGre}) EXPECT_LT(vib(m, 4).amplitude_raw, 0.3);
}
