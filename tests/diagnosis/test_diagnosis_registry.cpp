// The diagnosis takes its models from the engine's registry: the base models' fitted parameters,
// ranges, scales and starting values come from the traits tables' fit ranges (ParamDef::fit),
// and both diagnosis schemas list exactly the registered models.
#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/diagnosis/detail/diagnose_scale.h"
#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/diagnosis/diagnose_suite.h"
#include "stickslip/diagnosis/diagnosis_request.h"
#include "stickslip/engine/registry.h"
#include "stickslip/measured/synth.h"

namespace stickslip::diagnosis {
namespace {

using json = nlohmann::json;

json model_ids() {
  json out = json::array();
  for (const engine::ModelTraits& t : engine::all_model_traits()) out.push_back(t.info->name);
  return out;
}

const BaseCalibration* calibration_of(const Diagnosis& d, engine::ModelKind m) {
  for (const BaseCalibration& c : d.calibrations)
    if (c.model == m) return &c;
  return nullptr;
}

// A base model that takes no catalogue effect (ModelInfo::effects false: gms) cannot carry a
// candidate. Alone, it is the base, and the candidate is "not tested" with a note that names it
// (not a failed simulation). Beside lugre, on data that gms fits best (made by gms itself;
// checked below), the candidates run on lugre and are fitted; the note gives both held-out
// scores.
TEST(DiagnosisRegistry, CandidatesRunOnTheBestBaseThatTakesEffects) {
  const engine::ModelKind gms = engine::model_from_string("gms");
  const engine::ModelKind lugre = engine::model_from_string("lugre");
  ASSERT_FALSE(engine::model_traits(gms).info->effects);
  ASSERT_TRUE(engine::model_traits(lugre).info->effects);
  measured::SynthOptions made = hidden_case_dataset(hidden_case("clean_white"), 1000, SuiteDatasets::kCi);
  made.model = engine::SimConfig::seed(gms, 0.0);
  const measured::MeasuredDataset data = measured::synthesize(made);
  DiagnoseOptions o = hidden_case_options(SuiteDatasets::kCi);
  o.candidates = {engine::ExtensionKind::kDrift};
  o.whole_run_holdout = false;

  o.models = {gms};
  const Diagnosis alone = diagnose(data, o);
  EXPECT_EQ(alone.base_model, gms);
  EXPECT_EQ(alone.cause, "none");
  ASSERT_EQ(alone.candidates.size(), 1u);
  EXPECT_EQ(alone.candidates[0].status, "not tested: the base takes no catalogue effect (base_note)");
  EXPECT_NE(alone.base_note.find("gms (held-out RMSE"), std::string::npos) << alone.base_note;
  EXPECT_NE(alone.base_note.find("no calibrated base that does"), std::string::npos) << alone.base_note;
  EXPECT_EQ(to_json(alone)["base_note"], alone.base_note);

  o.models = {gms, lugre};
  const Diagnosis both = diagnose(data, o);
  const BaseCalibration* g = calibration_of(both, gms);
  const BaseCalibration* l = calibration_of(both, lugre);
  ASSERT_TRUE(g && l);
  ASSERT_LT(g->rmse_heldout, l->rmse_heldout) << "the premise: gms fits this dataset best";
  EXPECT_EQ(both.base_model, lugre) << summary_text(both);
  EXPECT_NE(both.base_note.find("tested on the best base that does, lugre (held-out RMSE"), std::string::npos)
      << both.base_note;
  ASSERT_EQ(both.candidates.size(), 1u);
  EXPECT_EQ(both.candidates[0].status, "ok") << summary_text(both);
  EXPECT_EQ(both.cause, "none") << summary_text(both);  // gms's data have no drift
  EXPECT_NE(summary_text(both).find(both.base_note), std::string::npos);

}

TEST(DiagnosisRegistry, SchemasListTheRegisteredModels) {
  const json result = json::parse(diagnosis_schema_text());
  EXPECT_EQ(result["$defs"]["model"]["enum"], model_ids());
  const json request = json::parse(diagnosis_request_schema_text());
  EXPECT_EQ(request["$defs"]["options"]["properties"]["models"]["items"]["enum"], model_ids());
}

// Every fitted parameter of every model, in table order, with its range and scale; the start
// lies inside the range for measured levels over two decades; a ratio fit is named "a/b".
TEST(DiagnosisRegistry, BaseSpecsAreTheTraitsFitRanges) {
  for (const engine::ModelTraits& t : engine::all_model_traits()) {
    for (const auto& [slip, stick] : {std::pair{0.2, 0.3}, {8.3, 11.1}, {40.0, 45.0}}) {
      const auto specs = detail::base_specs(t.kind, slip, stick);
      std::size_t k = 0;
      for (const engine::ParamDef& p : t.params) {
        if (!p.fit.fitted()) continue;
        ASSERT_LT(k, specs.size()) << t.info->name;
        const detail::ParamSpec& s = specs[k++];
        const std::string name =
            p.fit.relative_to ? std::string(p.name) + "/" + p.fit.relative_to : p.name;
        EXPECT_EQ(s.name, name) << t.info->name;
        EXPECT_EQ(s.lo, p.fit.lo) << name;
        EXPECT_EQ(s.hi, p.fit.hi) << name;
        EXPECT_EQ(s.log, p.fit.scale == engine::FitScale::kLog) << name;
        EXPECT_GE(s.init, s.lo) << t.info->name << " " << name << " at " << slip;
        EXPECT_LE(s.init, s.hi) << t.info->name << " " << name << " at " << slip;
        if (!p.fit.start) {
          EXPECT_EQ(s.init, p.def) << name;
        }
      }
      EXPECT_EQ(k, specs.size()) << t.info->name;
      EXPECT_FALSE(specs.empty()) << t.info->name << " has nothing to fit";
    }
  }
}

// The fitted parameters start from the measured levels: a force-level start follows them.
TEST(DiagnosisRegistry, ForceLevelStartsFollowTheMeasuredLevels) {
  for (const engine::ModelTraits& t : engine::all_model_traits()) {
    const auto low = detail::base_specs(t.kind, 4.0, 5.0);
    const auto high = detail::base_specs(t.kind, 16.0, 20.0);
    for (std::size_t k = 0; k < low.size(); ++k)
      if (low[k].name == "F_C" || low[k].name == "F_S") {
        EXPECT_LT(low[k].init, high[k].init) << t.info->name;
      }
  }
}

const detail::ParamSpec& spec_named(const std::vector<detail::ParamSpec>& specs,
                                    const std::string& name) {
  for (const detail::ParamSpec& s : specs)
    if (s.name == name) return s;
  throw std::runtime_error("no spec " + name);
}

// A coefficient of the normal load (rate-and-state's mu0, a, b) is scaled by the record's force
// level over its own F_N = Fz + m g: a 0.1 N record of a 30.7 g slider loaded by its weight
// alone starts at mu0 = 0.1 / 0.301, and the same record with Table 1's external load (29.4 N)
// at 0.1 / 29.7, inside the range in both cases (Table 1's range, 0.01-3, holds neither the
// second start nor, scaled by force alone, the first). Runs at two loads widen the range.
TEST(DiagnosisRegistry, NormalLoadCoefficientsFollowTheRecordsLevelOverItsNormalLoad) {
  const engine::ModelKind rs = engine::model_from_string("rate_state");
  const double level = 0.1, m = 0.0307;
  detail::RecordScales s;
  s.force = level / engine::FrictionParams{}["F_C"];
  s.kd = {1002.0};
  s.vd = {4.3e-3};
  for (const double Fz : {0.0, 29.4}) {
    const double FN = Fz + m * engine::Drive::kGravity;
    s.normal_load = {FN};
    const auto specs = detail::scaled_base_specs(rs, s, {level, 1.2 * level});
    for (const char* name : {"mu0", "a_rs", "b_rs"}) {
      const detail::ParamSpec& p = spec_named(specs, name);
      EXPECT_GE(p.init, p.lo) << name << " at F_N " << FN;
      EXPECT_LE(p.init, p.hi) << name << " at F_N " << FN;
    }
    const detail::ParamSpec& mu0 = spec_named(specs, "mu0");
    EXPECT_NEAR(mu0.init, level / FN, 1e-9 * level / FN) << "F_N " << FN;
    EXPECT_LT(mu0.lo, level / FN / 3.0);
    EXPECT_GT(mu0.hi, level / FN * 3.0);
    // a and b keep their ratio to mu0's scale: a_rs's default a/mu0 = 0.01/0.231.
    EXPECT_NEAR(spec_named(specs, "a_rs").init / mu0.init, 0.01 / 0.231, 0.001) << FN;
  }
  s.normal_load = {0.301, 30.0};
  s.kd = {1002.0, 1002.0};
  s.vd = {4.3e-3, 4.3e-3};
  const detail::ParamSpec& both = spec_named(detail::scaled_base_specs(rs, s, {level, 1.2 * level}), "mu0");
  EXPECT_LT(both.lo, level / 30.0);
  EXPECT_GT(both.hi, level / 0.301);
}

}  // namespace
}  // namespace stickslip::diagnosis
