// The diagnosis takes its models from the engine's registry: the base models' fitted parameters,
// ranges, scales and starting values come from the traits tables' fit ranges (ParamDef::fit),
// and both diagnosis schemas list exactly the registered models.
#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/diagnosis/diagnosis_request.h"
#include "stickslip/engine/registry.h"

namespace stickslip::diagnosis {
namespace {

using json = nlohmann::json;

json model_ids() {
  json out = json::array();
  for (const engine::ModelTraits& t : engine::all_model_traits()) out.push_back(t.info->name);
  return out;
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

}  // namespace
}  // namespace stickslip::diagnosis
