// Study specification: every problem reported with a JSON pointer, never an exception.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "stickslip/common/json_schema.h"
#include "stickslip/studies/spec.h"
#include "studies/spec_test_util.h"

namespace stickslip::studies {
namespace {

using namespace spec_test;

// ---------------------------------------------------------------- errors

TEST(SpecErrors, MalformedJsonReportsLineAndColumn) {
  const auto errors = errors_of("{\n  \"name\": \"x\",\n  \"base\": {\"m\": 1,}\n}");
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].pointer, "");
  EXPECT_NE(errors[0].message.find("line 3"), std::string::npos) << errors[0].message;
  EXPECT_NE(errors[0].message.find("column"), std::string::npos) << errors[0].message;
}

// A pathologically deep document is an error, not a stack overflow (the parser recurses per
// level); strings full of brackets do not count as nesting.
TEST(SpecErrors, DeepNestingIsRejectedBeforeParsing) {
  const auto errors = errors_of(std::string(200000, '[') + std::string(200000, ']'));
  ASSERT_EQ(errors.size(), 1u) << to_string(errors);
  EXPECT_NE(errors[0].message.find("nested more than 64 levels"), std::string::npos)
      << errors[0].message;
  EXPECT_EQ(common::json_nesting_depth(R"({"a": [[1], {"b": "[[[[[[{{{{"}]})"), 3u);
  const auto fine = parse_study(R"({"name": "x", "description": ")" + std::string(100, '[') +
                                 R"("})");
  EXPECT_TRUE(fine.ok()) << to_string(fine.errors);
}

TEST(SpecErrors, DuplicateKeysAreReported) {
  const auto errors = errors_of(R"({"name": "x", "base": {"m": 1, "m": 2}})");
  ASSERT_EQ(errors.size(), 1u) << to_string(errors);
  EXPECT_ERROR(errors, "/base/m", "duplicate field \"m\"");
}

TEST(SpecErrors, EveryUnknownFieldIsNamed) {
  auto doc = valid_doc();
  doc["colour"] = "red";
  doc["size"] = 3;
  doc["base"] = {{"mass", 1}};
  doc["design"]["axes"][0]["step"] = 1;
  doc["design"]["extra"] = true;
  const auto errors = errors_of(doc);
  EXPECT_ERROR(errors, "/colour", "unknown field \"colour\"");
  EXPECT_ERROR(errors, "/size", "unknown field \"size\"");
  EXPECT_ERROR(errors, "/base/mass", "unknown field \"mass\"");
  EXPECT_ERROR(errors, "/design/axes/0/step", "unknown field \"step\"");
  EXPECT_ERROR(errors, "/design/extra", "unknown field \"extra\"");
  EXPECT_EQ(errors.size(), 5u) << to_string(errors);
}

TEST(SpecErrors, WrongTypes) {
  auto doc = valid_doc();
  doc["base"] = {{"m", "heavy"}};
  doc["design"]["axes"][1]["values"] = {1000, "x"};
  doc["stages"] = json::object();
  const auto errors = errors_of(doc);
  EXPECT_ERROR(errors, "/base/m", "expected number, got string");
  EXPECT_ERROR(errors, "/stages", "expected array, got object");
  EXPECT_ERROR(errors, "/design/axes/1/values/1", "expected a number");
  EXPECT_EQ(errors.size(), 3u) << to_string(errors);
}

TEST(SpecErrors, NonPositiveMassAndContactStiffness) {
  auto doc = valid_doc();
  doc["base"] = {{"m", -1}, {"k_t", 0}};
  const auto errors = errors_of(doc);
  EXPECT_ERROR(errors, "/base/m", "must be > 0, got -1");
  EXPECT_ERROR(errors, "/base/k_t", "must be > 0, got 0");
  EXPECT_EQ(errors.size(), 2u) << to_string(errors);

  auto axis = valid_doc();
  axis["design"]["axes"][1] = {{"name", "m"}, {"values", {0.5, -1}}};
  const auto axis_errors = errors_of(axis);
  ASSERT_EQ(axis_errors.size(), 1u) << to_string(axis_errors);
  EXPECT_ERROR(axis_errors, "/design/axes/1/values/1", "must be > 0, got -1");
}

TEST(SpecErrors, UnknownModels) {
  auto doc = valid_doc();
  doc["design"]["axes"][0]["values"] = {"dahl", "lugre", "foo"};
  const auto errors = errors_of(doc);
  ASSERT_EQ(errors.size(), 1u) << to_string(errors);
  EXPECT_ERROR(errors, "/design/axes/0/values/2", "unknown model \"foo\"");

  auto base = valid_doc();
  base["base"] = {{"model", "coulomb"}};
  const auto base_errors = errors_of(base);
  ASSERT_EQ(base_errors.size(), 1u) << to_string(base_errors);
  EXPECT_ERROR(base_errors, "/base/model", "must be one of");
  EXPECT_ERROR(base_errors, "/base/model", "coulomb");
}

TEST(SpecErrors, EmptyAxisAndShortLinspace) {
  auto doc = valid_doc();
  doc["design"]["axes"][1]["values"] = json::array();
  auto errors = errors_of(doc);
  ASSERT_EQ(errors.size(), 1u) << to_string(errors);
  EXPECT_ERROR(errors, "/design/axes/1/values", "axis is empty");

  doc = valid_doc();
  doc["design"]["axes"][1] = {{"name", "k_d"}, {"linspace", {1000, 2000}}};
  errors = errors_of(doc);
  ASSERT_EQ(errors.size(), 1u) << to_string(errors);
  EXPECT_ERROR(errors, "/design/axes/1/linspace", "expected 3 numbers, got 2");

  doc["design"]["axes"][1] = {{"name", "k_d"}, {"linspace", {1000, 2000, 2.5}}};
  errors = errors_of(doc);
  EXPECT_ERROR(errors, "/design/axes/1/linspace/2", "integer");

  doc["design"]["axes"][1] = {{"name", "k_d"}};
  errors = errors_of(doc);
  EXPECT_ERROR(errors, "/design/axes/1", "exactly one of \"values\", \"linspace\", \"logspace\"");
}

TEST(SpecErrors, UnknownAndDuplicateNames) {
  auto doc = valid_doc();
  doc["design"]["axes"].push_back({{"name", "stiffness"}, {"values", {1}}});
  doc["design"]["axes"].push_back({{"name", "k_d"}, {"values", {1000}}});
  doc["design"]["axes"].push_back({{"name", "stage3.v_a"}, {"values", {0}}});
  const auto errors = errors_of(doc);
  EXPECT_ERROR(errors, "/design/axes/2/name", "unknown parameter \"stiffness\"");
  EXPECT_ERROR(errors, "/design/axes/3/name", "duplicate axis \"k_d\"");
  EXPECT_ERROR(errors, "/design/axes/4/name", "unknown parameter \"stage3.v_a\"");
  EXPECT_EQ(errors.size(), 3u) << to_string(errors);
}

TEST(SpecErrors, RunLimit) {
  const json doc = json::parse(R"({"name": "x", "design": {"type": "grid", "axes": [
      {"name": "k_d", "linspace": [1000, 2000, 400]},
      {"name": "m", "linspace": [0.5, 1, 300]}]}})");
  const auto errors = errors_of(doc);
  ASSERT_EQ(errors.size(), 1u) << to_string(errors);
  EXPECT_ERROR(errors, "/design", "120000 runs exceeds the limit of 100000");
  Limits generous;
  generous.max_runs = 200000;
  EXPECT_TRUE(parse_study(doc.dump(), generous).ok());
  Limits tight;
  tight.max_runs = 3;
  EXPECT_ERROR(errors_of(valid_doc(), tight), "/design", "4 runs exceeds the limit of 3");
  EXPECT_ERROR(errors_of(sampled("sobol", 1, 1000), tight), "/design", "5000 runs");
}

TEST(SpecErrors, StepAndDurationLimits) {
  auto doc = valid_doc();
  doc["integrator"] = {{"kind", "rk4"}, {"dt", 1.0}, {"dt_max", 1e-12}};
  doc["stages"] = {{{"duration", 3000}}, {{"duration", 1000}}};
  doc["design"]["axes"][1] = {{"name", "dt"}, {"values", {1e-6, 1e-10}}};
  const auto errors = errors_of(doc);
  EXPECT_ERROR(errors, "/integrator/dt", "must be within [1e-09, 0.01] s, got 1");
  EXPECT_ERROR(errors, "/integrator/dt_max", "must be within");
  EXPECT_ERROR(errors, "/stages", "total duration 4000 s exceeds the limit of 3600 s");
  EXPECT_ERROR(errors, "/design/axes/1/values/1", "must be within");
  EXPECT_EQ(errors.size(), 4u) << to_string(errors);

  Limits fast;
  fast.max_duration = 15;
  auto dur = valid_doc();
  dur["design"]["axes"][1] = {{"name", "duration"}, {"values", {12, 30}}};
  const auto dur_errors = errors_of(dur, fast);
  EXPECT_ERROR(dur_errors, "/stages", "total duration 20 s exceeds the limit of 15 s");
  EXPECT_ERROR(dur_errors, "/design/axes/1/values/1", "beyond the limit of 15 s");
}

TEST(SpecErrors, BaseMustSatisfySimConfigIsValid) {
  auto doc = valid_doc();
  doc["base"] = {{"F_S", 5}};  // below the default F_C = 8.3, used by lugre in the model axis
  const auto errors = errors_of(doc);
  ASSERT_EQ(errors.size(), 1u) << to_string(errors);
  EXPECT_ERROR(errors, "/base/F_S", "must be >= F_C = 8.3, got 5");
}

TEST(SpecErrors, RangeProblems) {
  auto doc = sampled("lhs", 1, 10);
  doc["design"]["ranges"][0]["max"] = 5;                // min 9 > max 5
  doc["design"]["ranges"][1]["min"] = 0;                // log scale with min 0
  doc["design"]["ranges"].push_back({{"name", "model"}, {"min", 0}, {"max", 1}});
  const auto errors = errors_of(doc);
  EXPECT_ERROR(errors, "/design/ranges/0", "min 9 is greater than max 5");
  EXPECT_ERROR(errors, "/design/ranges/1/min", "log scale needs min > 0");
  EXPECT_ERROR(errors, "/design/ranges/3/name", "\"model\" cannot be sampled");
  EXPECT_EQ(errors.size(), 3u) << to_string(errors);

  auto missing = sampled("sobol", 1, 8);
  missing["design"].erase("ranges");
  EXPECT_ERROR(errors_of(missing), "/design/ranges", "required for friction models");
}

TEST(SpecErrors, SeveralErrorsAreAllReported) {
  auto doc = valid_doc();
  doc["name"] = "bad name";
  doc["unknown"] = 1;
  doc["base"] = {{"m", 0}, {"k_t", -5}};
  doc["integrator"] = {{"kind", "euler"}};
  doc["design"]["axes"][0]["values"] = {"dahl", "foo"};
  doc["design"]["axes"].push_back({{"name", "v_d"}, {"linspace", {0.001, 0.002}}});
  doc["design"]["axes"].push_back({{"name", "h_t"}, {"values", json::array()}});
  const auto errors = errors_of(doc);
  EXPECT_ERROR(errors, "/name", "must match the pattern");
  EXPECT_ERROR(errors, "/unknown", "unknown field \"unknown\"");
  EXPECT_ERROR(errors, "/base/m", "must be > 0, got 0");
  EXPECT_ERROR(errors, "/base/k_t", "must be > 0, got -5");
  EXPECT_ERROR(errors, "/integrator/kind", "\"euler\"");
  EXPECT_ERROR(errors, "/design/axes/0/values/1", "unknown model \"foo\"");
  EXPECT_ERROR(errors, "/design/axes/2/linspace", "expected 3 numbers, got 2");
  EXPECT_ERROR(errors, "/design/axes/3/values", "axis is empty");
  EXPECT_EQ(errors.size(), 8u) << to_string(errors);
}

// Replacing any node of a valid spec with junk never throws: the result is a spec or errors.
void collect_pointers(const json& node, const std::string& where, std::vector<std::string>* out) {
  out->push_back(where);
  if (node.is_object())
    for (const auto& [key, sub] : node.items()) collect_pointers(sub, common::pointer_append(where, key), out);
  if (node.is_array())
    for (std::size_t i = 0; i < node.size(); ++i)
      collect_pointers(node[i], common::pointer_append(where, i), out);
}

TEST(SpecErrors, AnyNodeReplacedByJunkGivesErrorsNotExceptions) {
  const std::vector<json> junk = {nullptr, "x", -1, 0, 2.5, 1e300, json::array(),
                                  json::object(), json::array({1, "a"}), true};
  const std::vector<json> docs = {
      json::parse(read_text("studies/paper-map.json")), sampled("morris", 1, 3),
      sampled("lhs", 1, 4),
      json::parse(R"({"name": "i", "base": {"model": "sobol_g", "a": [1, 2]},
                      "design": {"type": "list", "points": [{"x1": 0.5, "x2": 0.1}]}})")};
  std::size_t rejected = 0, cases = 0;
  for (const auto& doc : docs) {
    std::vector<std::string> pointers;
    collect_pointers(doc, "", &pointers);
    for (const auto& p : pointers) {
      for (const auto& j : junk) {
        json bad = doc;
        bad[json::json_pointer(p)] = j;
        ParseResult r;
        ASSERT_NO_THROW(r = parse_study(bad.dump())) << p << " = " << j.dump();
        EXPECT_NE(r.spec.has_value(), !r.errors.empty()) << p << " = " << j.dump();
        for (const auto& e : r.errors) EXPECT_FALSE(e.message.empty());
        if (r.spec && r.spec->run_count() > 0) {
          EXPECT_NO_THROW(r.spec->point(r.spec->run_count() - 1)) << p << " = " << j.dump();
        }
        rejected += r.spec ? 0 : 1;
        ++cases;
      }
    }
  }
  EXPECT_GT(rejected, cases / 2);
}

}  // namespace
}  // namespace stickslip::studies
