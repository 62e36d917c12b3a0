// Study specification: parsing, designs and the canonical form (errors: test_spec_errors.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>

#include "stickslip/common/json_schema.h"
#include "stickslip/studies/sensitivity.h"
#include "stickslip/studies/spec.h"
#include "studies/spec_test_util.h"

namespace stickslip::studies {
namespace {

using namespace spec_test;

// ---------------------------------------------------------------- shipped studies

TEST(ShippedStudies, PaperMapHas204RunsOverFourModelsAndVaOverVd) {
  const auto spec = parse_ok(read_text("studies/paper-map.json"));
  EXPECT_EQ(spec.name(), "paper-map");
  ASSERT_EQ(spec.run_count(), 204u);
  EXPECT_FALSE(spec.is_analytic());
  EXPECT_EQ(spec.trace_rate(), 0.0);
  EXPECT_FALSE(spec.canonical()["outputs"].contains("traces"));

  const auto first = spec.point(0);
  EXPECT_EQ(first.model, "dahl");
  EXPECT_EQ(first.value("va_over_vd"), 0.0);
  EXPECT_EQ(first.value("v_a"), 0.0);
  const auto p = spec.point(51 + 3);  // karnopp, 4th step
  EXPECT_EQ(p.model, "karnopp");
  EXPECT_DOUBLE_EQ(*p.value("va_over_vd"), 0.3);
  EXPECT_DOUBLE_EQ(*p.value("v_a"), 0.3e-3);
  const auto last = spec.point(203);
  EXPECT_EQ(last.model, "lugre");
  EXPECT_EQ(last.value("va_over_vd"), 5.0);
  EXPECT_DOUBLE_EQ(*last.value("v_a"), 5e-3);

  const engine::SimConfig c = spec.config_for(p);
  EXPECT_EQ(c.model, engine::model_kind<engine::Karnopp>);
  ASSERT_EQ(c.stages.size(), 2u);
  EXPECT_EQ(c.stages[0].duration, 10.0);
  EXPECT_EQ(c.stages[0].v_a, 0.0);
  EXPECT_EQ(c.stages[1].duration, 10.0);
  EXPECT_DOUBLE_EQ(c.stages[1].v_a, 0.3e-3);
  EXPECT_EQ(c.stages[1].f, 1500.0);
  EXPECT_EQ(c.integrator.kind, engine::IntegratorKind::kAdaptive);
  EXPECT_EQ(c.drive.m, 0.665);
  EXPECT_EQ(c.drive.k_d, 11700.0);
  EXPECT_EQ(c.drive.v_d, 1e-3);
}

TEST(ShippedStudies, PaperFiguresHas16RunsWithTraces) {
  const auto spec = parse_ok(read_text("studies/paper-figures.json"));
  ASSERT_EQ(spec.run_count(), 16u);
  EXPECT_EQ(spec.trace_rate(), 2000.0);
  std::set<std::pair<std::string, double>> seen;
  for (std::size_t i = 0; i < spec.run_count(); ++i) {
    const auto p = spec.point(i);
    seen.emplace(p.model, *p.value("v_a"));
    EXPECT_EQ(spec.config_for(p).trace.rate, 2000.0);
  }
  std::set<std::pair<std::string, double>> want;
  for (const char* m : {"dahl", "karnopp", "reset_integrator", "lugre"})
    for (double va : {0.0, 0.2e-3, 1.1e-3, 4e-3}) want.emplace(m, va);
  EXPECT_EQ(seen, want);
  const auto c = spec.config_for(spec.point(4 * 3 + 2));  // lugre, 1.1 mm/s
  EXPECT_EQ(c.model, engine::model_kind<engine::LuGre>);
  EXPECT_EQ(c.stages[0].v_a, 0.0);
  EXPECT_EQ(c.stages[1].v_a, 1.1e-3);
}

// ---------------------------------------------------------------- grid

TEST(GridDesign, FirstAxisSlowestAndLinspaceLogspaceValues) {
  const auto spec = parse_ok(json::parse(R"({"name": "g", "design": {"type": "grid", "axes": [
      {"name": "model", "values": ["dahl", "lugre"]},
      {"name": "va_over_vd", "linspace": [0, 5, 51]},
      {"name": "k_d", "logspace": [3, 5, 9]}]}})"));
  ASSERT_EQ(spec.run_count(), 2u * 51u * 9u);
  // index = ((model * 51) + va) * 9 + k_d
  const auto p = spec.point((1 * 51 + 3) * 9 + 4);
  EXPECT_EQ(p.model, "lugre");
  ASSERT_EQ(p.values.size(), 3u);  // va_over_vd, k_d, then the derived v_a
  EXPECT_EQ(p.values[0].first, "va_over_vd");
  EXPECT_EQ(p.values[1].first, "k_d");
  EXPECT_EQ(p.values[2].first, "v_a");
  EXPECT_DOUBLE_EQ(p.values[0].second, 0.3);
  EXPECT_DOUBLE_EQ(p.values[1].second, 1e4);
  EXPECT_EQ(spec.point(0).model, "dahl");
  EXPECT_EQ(spec.point(8).value("k_d"), 1e5);   // fastest axis ends exactly
  EXPECT_EQ(spec.point(9).value("k_d"), 1e3);
  EXPECT_EQ(spec.point(9).value("va_over_vd"), 0.1);
  EXPECT_EQ(spec.point(50 * 9).value("va_over_vd"), 5.0);  // linspace ends exactly

  const auto& axes = spec.design().axes;
  ASSERT_EQ(axes.size(), 3u);
  for (std::size_t k = 0; k < 51; ++k) EXPECT_NEAR(axes[1].at(k), 0.1 * k, 1e-12);
  for (std::size_t k = 0; k < 9; ++k) EXPECT_NEAR(axes[2].at(k), std::pow(10.0, 3 + 0.25 * k),
                                                  1e-9 * std::pow(10.0, 3 + 0.25 * k));
}

TEST(GridDesign, LargeGridIsEnumeratedOnDemand) {
  const auto spec = parse_ok(json::parse(R"({"name": "big", "design": {"type": "grid", "axes": [
      {"name": "k_d", "linspace": [1000, 100000, 1000]},
      {"name": "m", "linspace": [0.1, 1, 100]}]}})"));
  ASSERT_EQ(spec.run_count(), 100000u);
  const auto p = spec.point(99999);
  EXPECT_EQ(p.value("k_d"), 100000.0);
  EXPECT_EQ(p.value("m"), 1.0);
  EXPECT_THROW(spec.point(100000), std::out_of_range);
}

TEST(GridDesign, VaOverVdIsResolvedAfterVdWhateverTheAxisOrder) {
  auto doc = [](bool ratio_first) {
    json a = {{"name", "va_over_vd"}, {"values", {0.5, 2.0}}};
    json b = {{"name", "v_d"}, {"values", {1e-3, 3e-3}}};
    return json{{"name", "o"},
                {"design", {{"type", "grid"}, {"axes", ratio_first ? json{a, b} : json{b, a}}}}};
  };
  const auto s1 = parse_ok(doc(true));
  const auto s2 = parse_ok(doc(false));
  std::map<std::pair<double, double>, double> v1, v2;
  for (std::size_t i = 0; i < 4; ++i) {
    const auto p1 = s1.point(i), p2 = s2.point(i);
    v1[{*p1.value("va_over_vd"), *p1.value("v_d")}] = *p1.value("v_a");
    v2[{*p2.value("va_over_vd"), *p2.value("v_d")}] = *p2.value("v_a");
    EXPECT_DOUBLE_EQ(s1.config_for(p1).stages[1].v_a,
                     *p1.value("va_over_vd") * *p1.value("v_d"));
    EXPECT_DOUBLE_EQ(s2.config_for(p2).stages[1].v_a,
                     *p2.value("va_over_vd") * *p2.value("v_d"));
  }
  EXPECT_EQ(v1, v2);
  EXPECT_DOUBLE_EQ((v1[{2.0, 3e-3}]), 6e-3);
}

// ---------------------------------------------------------------- base shorthands

TEST(BaseShorthands, StageAndIntegratorNamesInBaseMoveToTheirSections) {
  const auto spec = parse_ok(json::parse(R"({"name": "sh", "base": {"model": "karnopp",
      "v_a": 0.0011, "t_on": 5, "stage2.f": 1000, "dt": 2e-6}})"));
  const engine::SimConfig c = spec.config_for(spec.point(0));
  ASSERT_EQ(c.stages.size(), 2u);
  EXPECT_EQ(c.stages[0].duration, 5.0);
  EXPECT_EQ(c.stages[1].duration, 15.0);  // the run keeps its end time
  EXPECT_EQ(c.stages[0].v_a, 0.0);        // stage 1 is the still base
  EXPECT_EQ(c.stages[1].v_a, 0.0011);
  EXPECT_EQ(c.stages[1].f, 1000.0);
  EXPECT_EQ(c.stages[0].f, 1500.0);
  EXPECT_EQ(c.integrator.dt, 2e-6);
  const auto& canon = spec.canonical();
  EXPECT_FALSE(canon["base"].contains("v_a"));
  EXPECT_FALSE(canon["base"].contains("dt"));
  EXPECT_EQ(canon["stages"][1]["v_a"], 0.0011);
  EXPECT_EQ(canon["integrator"]["dt"], 2e-6);
  EXPECT_EQ(parse_ok(spec.canonical_json()).canonical(), canon);
}

TEST(BaseShorthands, ConflictsAndBadStagesAreReported) {
  const auto errors = errors_of(json::parse(R"({"name": "sh",
      "base": {"dt": 2e-6, "stage3.v_a": 0.001, "stage0.f": 3, "speed": 1},
      "integrator": {"dt": 1e-6}})"));
  EXPECT_ERROR(errors, "/base/dt", "also given as /integrator/dt");
  EXPECT_ERROR(errors, "/base/stage3.v_a", "refers to stage 3 but the run has 2 stage(s)");
  EXPECT_ERROR(errors, "/base/stage0.f", "unknown field \"stage0.f\"");
  EXPECT_ERROR(errors, "/base/speed", "names matching ^stage");
  EXPECT_EQ(errors.size(), 4u) << to_string(errors);
}

// ---------------------------------------------------------------- list

TEST(ListDesign, PointsInOrderWithSortedCanonicalNames) {
  const auto spec = parse_ok(json::parse(R"({"name": "l", "base": {"model": "dahl"},
    "design": {"type": "list", "points": [
      {"model": "lugre", "va_over_vd": 0.2},
      {"F_slip": 7, "k_d": 9000},
      {}]}})"));
  ASSERT_EQ(spec.run_count(), 3u);
  const auto p0 = spec.point(0);
  EXPECT_EQ(p0.model, "lugre");
  EXPECT_DOUBLE_EQ(*p0.value("v_a"), 0.2e-3);
  const auto p1 = spec.point(1);
  EXPECT_EQ(p1.model, "dahl");
  ASSERT_EQ(p1.values.size(), 2u);
  EXPECT_EQ(p1.values[0].first, "F_C");  // F_slip is stored as F_C, names sorted
  EXPECT_EQ(p1.values[1].first, "k_d");
  EXPECT_EQ(spec.config_for(p1).friction["F_C"], 7.0);
  EXPECT_EQ(spec.canonical_point_json(p1), R"({"F_C":7.0,"k_d":9000.0,"model":"dahl"})");
  EXPECT_TRUE(spec.point(2).values.empty());
  EXPECT_EQ(spec.config_for(spec.point(2)).model, engine::model_kind<engine::Dahl>);
}

TEST(ListDesign, MissingDesignIsOneRunOfTheBase) {
  const auto spec = parse_ok(json{{"name", "single"}, {"base", {{"m", 1.5}}}});
  ASSERT_EQ(spec.run_count(), 1u);
  EXPECT_EQ(spec.config_for(spec.point(0)).drive.m, 1.5);
  EXPECT_EQ(spec.canonical()["design"], json::parse(R"({"type":"list","points":[{}]})"));
}

// ---------------------------------------------------------------- sampled designs


TEST(SampledDesigns, RandomIsDeterministicBySeedAndInRange) {
  const auto a = parse_ok(sampled("random", 7, 50));
  const auto b = parse_ok(sampled("random", 7, 50));
  const auto c = parse_ok(sampled("random", 8, 50));
  ASSERT_EQ(a.run_count(), 50u);
  EXPECT_EQ(all_points(a), all_points(b));
  EXPECT_NE(all_points(a), all_points(c));
  for (std::size_t i = 0; i < a.run_count(); ++i) {
    const auto p = a.point(i);
    EXPECT_EQ(p.values.size(), 4u);  // 3 ranges + derived v_a
    EXPECT_GE(*p.value("F_S"), 9.0);
    EXPECT_LE(*p.value("F_S"), 13.0);
    EXPECT_GE(*p.value("k_d"), 1e3);
    EXPECT_LE(*p.value("k_d"), 1e5);
    EXPECT_DOUBLE_EQ(*p.value("v_a"), *p.value("va_over_vd") * 1e-3);
  }
}

TEST(SampledDesigns, LhsPutsExactlyOnePointInEachBinOfEveryColumn) {
  const std::size_t n = 37;
  const auto spec = parse_ok(sampled("lhs", 3, n));
  ASSERT_EQ(spec.run_count(), n);
  const auto& ranges = spec.design().ranges;
  for (std::size_t j = 0; j < ranges.size(); ++j) {
    std::set<long> bins;
    for (std::size_t i = 0; i < n; ++i) {
      const double u = spec.unit_point(i)[j];
      bins.insert(static_cast<long>(std::floor(u * n)));
      // The mapped value lies in the same bin, in the range's own scale.
      const double v = *spec.point(i).value(ranges[j].name);
      const double w = ranges[j].log ? (std::log10(v) - std::log10(ranges[j].min)) /
                                           (std::log10(ranges[j].max) - std::log10(ranges[j].min))
                                     : (v - ranges[j].min) / (ranges[j].max - ranges[j].min);
      EXPECT_EQ(static_cast<long>(std::floor(w * n)), static_cast<long>(std::floor(u * n)));
    }
    EXPECT_EQ(bins.size(), n) << "column " << j;
    EXPECT_EQ(*bins.begin(), 0);
    EXPECT_EQ(*bins.rbegin(), static_cast<long>(n) - 1);
  }
  EXPECT_EQ(all_points(spec), all_points(parse_ok(sampled("lhs", 3, n))));
  EXPECT_NE(all_points(spec), all_points(parse_ok(sampled("lhs", 4, n))));
}

TEST(SampledDesigns, SobolIsTheSaltelliDesignWithNTimesDPlus2Runs) {
  const auto spec = parse_ok(sampled("sobol", 5, 16));
  const std::size_t d = 3;
  ASSERT_EQ(spec.run_count(), 16u * (d + 2));
  const auto rows = sensitivity::saltelli_design(16, d, 5);
  for (std::size_t i = 0; i < spec.run_count(); ++i) {
    EXPECT_EQ(spec.unit_point(i), rows[i]);
    EXPECT_DOUBLE_EQ(*spec.point(i).value("F_S"), 9 + 4 * rows[i][0]);
  }
  EXPECT_EQ(spec.variables(), (std::vector<std::string>{"F_S", "k_d", "va_over_vd"}));
  EXPECT_EQ(all_points(spec), all_points(parse_ok(sampled("sobol", 5, 16))));
  EXPECT_NE(all_points(spec), all_points(parse_ok(sampled("sobol", 6, 16))));
}

TEST(SampledDesigns, MorrisHasDPlus1TimesRRuns) {
  const auto spec = parse_ok(sampled("morris", 2, 6));
  ASSERT_EQ(spec.run_count(), (3u + 1) * 6);
  EXPECT_EQ(spec.design().levels, 4u);  // default
  EXPECT_EQ(spec.canonical()["design"]["levels"], 4);
  const auto rows = sensitivity::morris_design(6, 3, 4, 2);
  for (std::size_t i = 0; i < spec.run_count(); ++i) EXPECT_EQ(spec.unit_point(i), rows[i]);
  EXPECT_EQ(all_points(spec), all_points(parse_ok(sampled("morris", 2, 6))));
}

TEST(SampledDesigns, GridHasNoUnitPoints) {
  EXPECT_THROW(parse_ok(valid_doc()).unit_point(0), std::logic_error);
}

// ---------------------------------------------------------------- invalid points

TEST(ConfigFor, InvalidPointThrowsInvalidParameterNamingTheField) {
  const auto spec = parse_ok(json::parse(R"({"name": "fs", "design": {"type": "grid", "axes": [
      {"name": "F_S", "values": [5, 10]}]}})"));  // base F_C = 8.3
  try {
    spec.config_for(spec.point(0));
    FAIL() << "F_S = 5 < F_C should be rejected";
  } catch (const engine::InvalidParameter& e) {
    EXPECT_EQ(e.field(), "F_S");
    EXPECT_NE(std::string(e.what()).find('5'), std::string::npos);
  }
  EXPECT_EQ(spec.config_for(spec.point(1)).friction["F_S"], 10.0);

  DesignPoint bad = spec.point(1);
  bad.values.emplace_back("m", -1.0);
  EXPECT_THROW(spec.config_for(bad), engine::InvalidParameter);
  bad = spec.point(1);
  bad.model = "coulomb";
  EXPECT_THROW(spec.config_for(bad), engine::InvalidParameter);
}

TEST(ConfigFor, FsBelowFcPolicyRaisesFsOnlyWhenAsked) {
  const json doc = json::parse(R"({"name": "fs", "design": {"type": "grid", "axes": [
      {"name": "model", "values": ["lugre", "karnopp", "dahl"]},
      {"name": "F_S", "values": [5, 10]}]}})");  // base F_C = 8.3
  const auto strict = parse_ok(doc);
  EXPECT_EQ(strict.F_S_below_F_C(), FsBelowFc::kFail);
  EXPECT_FALSE(strict.canonical().contains("F_S_below_F_C"));  // old specs keep their hash
  EXPECT_THROW(strict.config_for(strict.point(0)), engine::InvalidParameter);
  EXPECT_FALSE(strict.raises_F_S(strict.point(0)));

  json raising = doc;
  raising["F_S_below_F_C"] = "raise_F_S_to_F_C";
  const auto spec = parse_ok(raising);
  EXPECT_EQ(spec.F_S_below_F_C(), FsBelowFc::kRaiseToFc);
  EXPECT_EQ(spec.canonical()["F_S_below_F_C"], "raise_F_S_to_F_C");
  EXPECT_EQ(parse_ok(spec.canonical_json()).canonical(), spec.canonical());
  EXPECT_NE(spec.canonical_json(), strict.canonical_json());
  // points: (lugre, 5) (lugre, 10) (karnopp, 5) (karnopp, 10) (dahl, 5) (dahl, 10)
  for (std::size_t i : {0u, 2u}) {
    EXPECT_TRUE(spec.raises_F_S(spec.point(i))) << i;
    const engine::SimConfig c = spec.config_for(spec.point(i));
    EXPECT_EQ(c.friction["F_S"], 8.3) << i;
    EXPECT_EQ(c.friction["F_C"], 8.3) << i;
  }
  for (std::size_t i : {1u, 3u, 5u}) {
    EXPECT_FALSE(spec.raises_F_S(spec.point(i))) << i;
    EXPECT_EQ(spec.config_for(spec.point(i)).friction["F_S"], 10.0) << i;
  }
  // Dahl does not use F_S: nothing to raise, and its F_S = 5 < F_C still breaks SimConfig's rule.
  EXPECT_FALSE(spec.raises_F_S(spec.point(4)));
  // The policy repairs only F_S < F_C: any other bad value still fails, naming it.
  DesignPoint bad = spec.point(0);
  bad.values.emplace_back("m", -1.0);
  EXPECT_THROW(spec.config_for(bad), engine::InvalidParameter);

  json wrong = doc;
  wrong["F_S_below_F_C"] = "clamp";
  const ParseResult r = parse_study(wrong.dump());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.errors.at(0).pointer, "/F_S_below_F_C") << to_string(r.errors);
  json analytic = json::parse(R"({"name": "ishi", "base": {"model": "ishigami"},
      "F_S_below_F_C": "raise_F_S_to_F_C"})");
  const ParseResult ra = parse_study(analytic.dump());
  ASSERT_FALSE(ra.ok());
  EXPECT_EQ(ra.errors.at(0).pointer, "/F_S_below_F_C") << to_string(ra.errors);
}


// ---------------------------------------------------------------- analytic models

TEST(AnalyticSpecs, IshigamiSobolDesignWithDefaultRanges) {
  const auto spec = parse_ok(json::parse(
      R"({"name": "ishi", "base": {"model": "ishigami"}, "design": {"type": "sobol", "n": 32}})"));
  EXPECT_TRUE(spec.is_analytic());
  EXPECT_EQ(spec.analytic_model(), "ishigami");
  ASSERT_EQ(spec.run_count(), 32u * (3 + 2));
  const auto& ranges = spec.canonical()["design"]["ranges"];
  ASSERT_EQ(ranges.size(), 3u);
  EXPECT_EQ(ranges[2]["name"], "x3");
  EXPECT_DOUBLE_EQ(ranges[2]["min"].get<double>(), -std::numbers::pi);
  for (std::size_t i = 0; i < spec.run_count(); ++i) {
    const auto p = spec.point(i);
    EXPECT_EQ(p.model, "ishigami");
    const std::vector<double> x = {*p.value("x1"), *p.value("x2"), *p.value("x3")};
    for (double v : x) EXPECT_LE(std::abs(v), std::numbers::pi);
    EXPECT_DOUBLE_EQ(spec.analytic_value(p), sensitivity::ishigami(x, 7.0, 0.1));
  }
  EXPECT_THROW(spec.config_for(spec.point(0)), engine::InvalidParameter);
}

TEST(AnalyticSpecs, SobolGMorrisWithCoefficients) {
  const auto spec = parse_ok(json::parse(R"({"name": "g", "base": {"model": "sobol_g",
      "a": [78, 12, 0.5, 2, 97, 33]}, "design": {"type": "morris", "trajectories": 10}})"));
  EXPECT_EQ(spec.analytic_inputs(), 6u);
  ASSERT_EQ(spec.run_count(), (6u + 1) * 10);
  const std::vector<double> a = {78, 12, 0.5, 2, 97, 33};
  const auto p = spec.point(3);
  std::vector<double> x;
  for (const char* name : {"x1", "x2", "x3", "x4", "x5", "x6"}) x.push_back(*p.value(name));
  for (double v : x) {
    EXPECT_GE(v, 0.0);
    EXPECT_LE(v, 1.0);
  }
  EXPECT_DOUBLE_EQ(spec.analytic_value(p), sensitivity::sobol_g(x, a));
}

TEST(AnalyticSpecs, ProblemsAreReported) {
  auto errors = errors_of(R"({"name": "g", "base": {"model": "sobol_g"},
      "design": {"type": "sobol", "n": 8}})");
  EXPECT_ERROR(errors, "/base", "missing required field \"a\"");

  errors = errors_of(R"({"name": "i", "base": {"model": "ishigami", "m": 1},
      "stages": [{"duration": 1}],
      "design": {"type": "grid", "axes": [{"name": "x1", "values": [0]},
                                          {"name": "x4", "values": [0]}]}})");
  EXPECT_ERROR(errors, "/base/m", "not used by the analytic model ishigami");
  EXPECT_ERROR(errors, "/stages", "not used by the analytic model ishigami");
  EXPECT_ERROR(errors, "/design/axes/1/name", "unknown input \"x4\"");
  EXPECT_ERROR(errors, "/design/axes", "missing inputs x2, x3");
  EXPECT_EQ(errors.size(), 4u) << to_string(errors);

  errors = errors_of(R"({"name": "i", "base": {"model": "ishigami"},
      "design": {"type": "list", "points": [{"x1": 0, "x2": 1}]}})");
  EXPECT_ERROR(errors, "/design/points/0", "missing input x3");
}

// ---------------------------------------------------------------- canonical form and schema

TEST(Canonical, DefaultsFilledAndRoundTrip) {
  for (const char* file : {"studies/paper-map.json", "studies/paper-figures.json"}) {
    const auto spec = parse_ok(read_text(file));
    const auto& c = spec.canonical();
    EXPECT_EQ(c["base"]["F_S"], 11.1);
    EXPECT_EQ(c["base"]["k_t"], 71.318e6);
    EXPECT_EQ(c["integrator"]["dt_max"], 1e-4);
    EXPECT_FALSE(c.contains("$schema"));
    const auto again = parse_ok(spec.canonical_json());
    EXPECT_EQ(again.canonical(), c) << file;
    EXPECT_EQ(all_points(again), all_points(spec));
  }
  const auto analytic = parse_ok(json::parse(
      R"({"name": "ishi", "base": {"model": "ishigami"}, "design": {"type": "lhs", "n": 5}})"));
  EXPECT_EQ(parse_ok(analytic.canonical_json()).canonical(), analytic.canonical());
}

TEST(Schema, EmbeddedSchemaMatchesTheGeneratedFile) {
  std::ifstream in(std::string(STICKSLIP_SCHEMA_DIR) + "/study.schema.json");
  EXPECT_TRUE(study_schema() == json::parse(in))
      << "the schema embedded at build time differs from the one filled from "
         "schemas/study.schema.json (<build>/schemas/study.schema.json)";
}

TEST(Schema, DefaultsAndNamesAgreeWithTheEngine) {
  const engine::SimConfig defaults;
  const auto& base = study_schema()["$defs"]["base"]["properties"];
  for (const auto& [name, sub] : base.items()) {
    EXPECT_TRUE(sub.contains("description")) << name;
    if (name == "model" || name == "a" || name == "b") continue;
    if (engine::friction_option_index(name) >= 0) {  // a model option: a named choice
      EXPECT_EQ(sub["default"], engine::get_option(defaults, name)) << name;
      continue;
    }
    EXPECT_NO_THROW(engine::get_parameter(defaults, name)) << name;
    if (sub.contains("default")) {
      EXPECT_DOUBLE_EQ(sub["default"].get<double>(), engine::get_parameter(defaults, name)) << name;
    }
  }
  const auto& integ = study_schema()["$defs"]["integrator"]["properties"];
  EXPECT_DOUBLE_EQ(integ["dt"]["default"].get<double>(), defaults.integrator.dt);
  EXPECT_DOUBLE_EQ(integ["rtol"]["default"].get<double>(), defaults.integrator.rtol);
  EXPECT_DOUBLE_EQ(integ["atol"]["default"].get<double>(), defaults.integrator.atol);
  EXPECT_DOUBLE_EQ(integ["dt_max"]["default"].get<double>(), defaults.integrator.dt_max);
  EXPECT_DOUBLE_EQ(integ["max_steps"]["default"].get<double>(), defaults.integrator.max_steps);
  EXPECT_EQ(integ["kind"]["default"], to_string(defaults.integrator.kind));
  EXPECT_EQ(study_schema()["$defs"]["base"]["properties"]["model"]["default"],
            to_string(defaults.model));
}

// Every object in the schema is closed and every property documented. The design dispatcher
// ($defs/design) and if/then fragments only add constraints to closed objects.
void expect_closed_and_documented(const json& node, const std::string& where) {
  if (node.is_array()) {
    for (std::size_t i = 0; i < node.size(); ++i)
      expect_closed_and_documented(node[i], where + "/" + std::to_string(i));
    return;
  }
  if (!node.is_object()) return;
  if (node.contains("properties") && where != "/$defs/design") {
    EXPECT_EQ(node.value("additionalProperties", json(true)), json(false)) << where;
    for (const auto& [name, sub] : node["properties"].items()) {
      EXPECT_TRUE(sub.contains("description") || sub.contains("$ref")) << where << "/" << name;
      expect_closed_and_documented(sub, where + "/properties/" + name);
    }
  }
  for (const auto& [key, sub] : node.items())
    if (key != "properties" && key != "if" && key != "then")
      expect_closed_and_documented(sub, where + "/" + key);
}

TEST(Schema, ObjectsAreClosedAndDocumented) {
  const auto& schema = study_schema();
  EXPECT_EQ(schema["additionalProperties"], false);
  expect_closed_and_documented(schema, "");
  for (const auto& [name, def] : schema["$defs"].items())
    EXPECT_TRUE(def.contains("description")) << name;
}

}  // namespace
}  // namespace stickslip::studies
