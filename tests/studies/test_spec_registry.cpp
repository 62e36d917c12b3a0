// The study schema and the spec parser take the friction models from the engine's registry
// (engine/include/stickslip/engine/model_list.h): the model enum, one property per parameter
// with its unit, default and allowed range, the aliases, the options, the F_S >= F_C policy.
// The schema templates in schemas/ name no model and no friction parameter themselves.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "stickslip/engine/registry.h"
#include "stickslip/studies/spec.h"

namespace stickslip::studies {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

const json& base_properties() { return study_schema()["$defs"]["base"]["properties"]; }

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// "\"name\"", appended ('"' + std::string makes GCC 12 report a false -Wrestrict).
std::string quoted(const char* name) { return std::string("\"").append(name).append("\""); }

TEST(SchemaFromRegistry, ModelEnumIsTheRegisteredModelsThenTheAnalyticOnes) {
  json expected = json::array();
  for (const engine::ModelTraits& t : engine::all_model_traits()) expected.push_back(t.info->name);
  expected.push_back("ishigami");
  expected.push_back("sobol_g");
  const json& model = base_properties()["model"];
  EXPECT_EQ(model["enum"], expected);
  EXPECT_EQ(model["default"], engine::to_string(engine::SimConfig{}.model));
  for (const engine::ModelTraits& t : engine::all_model_traits())
    EXPECT_TRUE(contains(model["description"], t.info->name)) << t.info->name;
}

// The JSON Schema keywords of an allowed interval.
void expect_range(const json& prop, const engine::Interval& in, const std::string& name) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const char* lo_key = in.lo_open ? "exclusiveMinimum" : "minimum";
  const char* lo_other = in.lo_open ? "minimum" : "exclusiveMinimum";
  if (in.lo == -inf) {
    EXPECT_FALSE(prop.contains("minimum") || prop.contains("exclusiveMinimum")) << name;
  } else {
    EXPECT_EQ(prop.value(lo_key, json()), json(in.lo)) << name;
    EXPECT_FALSE(prop.contains(lo_other)) << name;
  }
  const char* hi_key = in.hi_open ? "exclusiveMaximum" : "maximum";
  if (in.hi == inf) {
    EXPECT_FALSE(prop.contains("maximum") || prop.contains("exclusiveMaximum")) << name;
  } else {
    EXPECT_EQ(prop.value(hi_key, json()), json(in.hi)) << name;
  }
  EXPECT_EQ(prop.value("type", json()), "number") << name;
}

TEST(SchemaFromRegistry, EveryFrictionParameterWithUnitDefaultRangeAndModels) {
  const json& base = base_properties();
  for (const engine::ParamDef& p : engine::kFrictionParameters) {
    ASSERT_TRUE(base.contains(p.name)) << p.name;
    const json& prop = base[p.name];
    const std::string text = prop["description"];
    const std::string unit = std::string("[").append(engine::unit_of(p.dim)).append("]");
    EXPECT_TRUE(contains(text, unit)) << p.name << ": " << text;
    EXPECT_EQ(prop["default"].get<double>(), p.def) << p.name;  // exactly
    expect_range(prop, p.allowed, p.name);
    for (const engine::ModelTraits& t : engine::all_model_traits())
      for (const engine::ParamDef& q : t.params)
        if (std::string(q.name) == p.name) {
          EXPECT_TRUE(contains(text, t.info->title)) << p.name << " used by " << t.info->title;
        }
    for (const engine::ModelTraits& t : engine::all_model_traits())
      for (const engine::Constraint& c : t.constraints)
        if (std::string(c.param) == p.name) {
          EXPECT_TRUE(contains(text, std::string(">= ") + c.at_least)) << p.name;
        }
    if (p.alias != nullptr) {
      ASSERT_TRUE(base.contains(p.alias)) << p.alias;
      EXPECT_FALSE(base[p.alias].contains("default")) << p.alias;
      EXPECT_TRUE(contains(base[p.alias]["description"], std::string("Alias of ") + p.name));
      expect_range(base[p.alias], p.allowed, p.alias);
    }
  }
  for (const engine::OptionDef& o : engine::kFrictionOptions) {
    ASSERT_TRUE(base.contains(o.name)) << o.name;
    json choices = json::array();
    for (const char* c : o.choices) choices.push_back(c);
    EXPECT_EQ(base[o.name]["enum"], choices) << o.name;
    EXPECT_EQ(base[o.name]["default"], o.choices[static_cast<std::size_t>(o.def)]) << o.name;
  }
}

// The spec accepts what the schema lists and nothing the registry does not know: every friction
// parameter (and alias) is a base field and a design variable, and the canonical form of a study
// that uses a model carries each of its parameters at its default (a study using none of the
// models beyond the seed's four carries theirs: test_spec_canonical_models.cpp).
TEST(SchemaFromRegistry, EveryParameterIsABaseFieldAndADesignVariable) {
  for (const engine::ModelTraits& t : engine::all_model_traits()) {
    const json doc = {{"name", "defaults"}, {"base", {{"model", t.info->name}}}};
    const auto r = parse_study(doc.dump());
    ASSERT_TRUE(r.ok()) << t.info->name << ": " << to_string(r.errors);
    const json& canonical = r.spec->canonical()["base"];
    for (const engine::ParamDef& p : t.params)
      EXPECT_EQ(canonical.value(p.name, json()), json(p.def)) << t.info->name << ": " << p.name;
  }
  for (const engine::ParamDef& p : engine::kFrictionParameters) {
    for (const char* name : {p.name, p.alias}) {
      if (name == nullptr) continue;
      const json spec = {{"name", "one"},
                         {"base", {{name, p.def}}},
                         {"design", {{"type", "grid"}, {"axes", {{{"name", name}, {"values", {p.def}}}}}}}};
      const auto one = parse_study(spec.dump());
      EXPECT_TRUE(one.ok()) << name << ": " << to_string(one.errors);
      if (one.ok()) {
        EXPECT_EQ(one.spec->point(0).values.at(0).first, p.name);  // alias: its parameter
      }
    }
  }
}

// The F_S_below_F_C policy raises F_S exactly for the models that require F_S >= F_C.
TEST(SpecFromRegistry, FsBelowFcPolicyFollowsTheModelsConstraints) {
  json points = json::array();
  for (const engine::ModelTraits& t : engine::all_model_traits())
    points.push_back({{"model", t.info->name}, {"F_S", 5.0}, {"F_C", 8.0}});
  const json spec = {{"name", "raise"},
                     {"F_S_below_F_C", "raise_F_S_to_F_C"},
                     {"design", {{"type", "list"}, {"points", points}}}};
  const auto r = parse_study(spec.dump());
  ASSERT_TRUE(r.ok()) << to_string(r.errors);
  for (std::size_t i = 0; i < engine::all_model_traits().size(); ++i) {
    const engine::ModelTraits& t = engine::all_model_traits()[i];
    bool requires_fs = false;
    for (const engine::Constraint& c : t.constraints)
      requires_fs = requires_fs || (std::string(c.param) == "F_S" && std::string(c.at_least) == "F_C");
    const DesignPoint p = r.spec->point(i);
    EXPECT_EQ(r.spec->raises_F_S(p), requires_fs) << t.info->name;
    EXPECT_EQ(r.spec->config_for(p).friction["F_S"], requires_fs ? 8.0 : 5.0) << t.info->name;
  }
}

// Every template in schemas/ leaves the models to the registry: no model id as a JSON string,
// and the study template describes no friction parameter itself.
TEST(SchemaFromRegistry, TemplatesNameNoModelAndNoFrictionParameter) {
  const std::string dir = std::string(STICKSLIP_SOURCE_DIR) + "/schemas/";
  int templates = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".json") continue;
    ++templates;
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    for (const engine::ModelTraits& t : engine::all_model_traits())
      EXPECT_FALSE(contains(text.str(), quoted(t.info->name)))
          << entry.path().filename() << " names the model " << t.info->name;
  }
  EXPECT_GE(templates, 3);
  std::ifstream in(dir + "study.schema.json");
  const json study = json::parse(in);
  const json& base = study["$defs"]["base"]["properties"];
  EXPECT_TRUE(base.contains("@friction_parameters@"));
  for (const engine::ParamDef& p : engine::kFrictionParameters) {
    EXPECT_FALSE(base.contains(p.name)) << "the template describes the parameter " << p.name;
    EXPECT_TRUE(p.alias == nullptr || !base.contains(p.alias)) << p.alias;
  }
}

}  // namespace
}  // namespace stickslip::studies
