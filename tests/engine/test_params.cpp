// Parameter validation: every bad value is rejected with the field and the value named.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"

using namespace stickslip::engine;

namespace {
std::string set_error(const char* name, double v) {
  SimConfig c;
  try {
    set_parameter(c, name, v);
  } catch (const InvalidParameter& e) {
    EXPECT_EQ(e.field(), name);
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Params, DefaultsAreTheSeeds) {
  const SimConfig c = SimConfig::seed(model_kind<LuGre>, 0.2e-3);
  EXPECT_DOUBLE_EQ(c.drive.m, 0.665);
  EXPECT_DOUBLE_EQ(c.drive.k_d, 11700);
  EXPECT_DOUBLE_EQ(c.drive.v_d, 1e-3);
  EXPECT_DOUBLE_EQ(c.friction["k_t"], 71.318e6);
  EXPECT_DOUBLE_EQ(c.friction["s0"], 1.1e-7);
  EXPECT_DOUBLE_EQ(c.friction["v_s"], 3.5e-4);
  ASSERT_EQ(c.stages.size(), 2u);
  EXPECT_DOUBLE_EQ(c.stages[0].v_a, 0.0);
  EXPECT_DOUBLE_EQ(c.stages[1].v_a, 0.2e-3);
  EXPECT_DOUBLE_EQ(c.stages[1].f, 1500);
  EXPECT_TRUE(c.IsValid());
}

TEST(Params, RejectsNonPositiveAndNonFiniteWithFieldAndValue) {
  EXPECT_NE(set_error("m", 0.0).find("m = 0"), std::string::npos);
  EXPECT_NE(set_error("m", -1.0).find("must be > 0"), std::string::npos);
  EXPECT_NE(set_error("k_t", -5).find("k_t = -5"), std::string::npos);
  EXPECT_NE(set_error("DV", 0).find("DV"), std::string::npos);
  EXPECT_NE(set_error("dt", 0).find("dt"), std::string::npos);
  EXPECT_NE(set_error("F_C", std::nan("")).find("finite"), std::string::npos);
  EXPECT_NE(set_error("k_d", std::numeric_limits<double>::infinity()).find("k_d = inf"),
            std::string::npos);
  EXPECT_NE(set_error("stage2.duration", 0).find("stage2.duration"), std::string::npos);
  EXPECT_NE(set_error("stage7.v_a", 1e-3).find("stage 7"), std::string::npos);
  EXPECT_NE(set_error("no_such_thing", 1).find("unknown parameter"), std::string::npos);
  EXPECT_THROW(model_from_string("coulomb"), InvalidParameter);
  EXPECT_THROW(integrator_from_string("euler"), InvalidParameter);
}

TEST(Params, CrossFieldConstraintsNamedByIsValid) {
  SimConfig c = SimConfig::seed(model_kind<LuGre>, 0);
  c.friction["F_S"] = 5.0;  // below F_C = 8.3
  std::vector<std::string> errors;
  EXPECT_FALSE(c.IsValid(&errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("F_S = 5"), std::string::npos);
  EXPECT_NE(errors[0].find("F_C"), std::string::npos);
  c.friction["k_t"] = -1;
  c.stages[1].duration = std::nan("");
  errors.clear();
  EXPECT_FALSE(c.IsValid(&errors));
  EXPECT_EQ(errors.size(), 3u) << "every broken constraint is reported";
}

TEST(Params, InvalidConfigGivesInvalidRunNotACrash) {
  SimConfig c = SimConfig::seed(model_kind<Karnopp>, 0);
  c.friction["DV"] = -1;
  const SimResult r = simulate(c);
  EXPECT_EQ(r.status, RunStatus::kInvalid);
  EXPECT_NE(r.reason.find("DV = -1"), std::string::npos);
  EXPECT_TRUE(r.stages.empty());
}

TEST(Params, DerivedSettersKeepTheRunConsistent) {
  SimConfig c = SimConfig::seed(model_kind<LuGre>, 1e-3);
  set_parameter(c, "t_on", 4.0);
  EXPECT_DOUBLE_EQ(c.stages[0].duration, 4.0);
  EXPECT_DOUBLE_EQ(c.total_duration(), 20.0);
  set_parameter(c, "duration", 10.0);
  EXPECT_DOUBLE_EQ(c.stages[0].duration, 4.0);
  EXPECT_DOUBLE_EQ(c.stages[1].duration, 6.0);
  set_parameter(c, "v_a", 2e-3);
  EXPECT_DOUBLE_EQ(c.stages[0].v_a, 0.0) << "stage 1 is the still base";
  EXPECT_DOUBLE_EQ(c.stages[1].v_a, 2e-3);
  EXPECT_THROW(set_parameter(c, "t_on", 12.0), InvalidParameter);
  for (const auto& n : parameter_names()) EXPECT_NO_THROW(get_parameter(c, n)) << n;
}
