// `stickslip validate DIAGNOSIS.json MANIFEST --out DIR` as a real process: validation.json follows
// schemas/validation.schema.json, every run has its CSV (t, Fd_measured, Fd_base, Fd_extended at
// every measured sample) and the base, the model that made the data, predicts it to about the
// noise; --quiet leaves stderr empty while the default reports the progress there; a diagnosis
// without calibrated models is exit 2 naming "models".
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <sstream>

#include <nlohmann/json.hpp>

#include "stickslip/common/json_schema.h"
#include "stickslip/diagnosis/validate.h"
#include "stickslip/measured/synth.h"
#include "support/cli_process.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json table1_diagnosis() {
  stickslip::diagnosis::CalibratedModel m;
  m.model = stickslip::engine::model_kind<stickslip::engine::LuGre>;
  const auto c = stickslip::engine::SimConfig::seed(m.model, 0.0);
  for (const auto& p : stickslip::engine::model_traits(m.model).params)
    m.params.emplace_back(p.name, stickslip::engine::get_parameter(c, p.name));
  m.offset = 0.05;
  return {{"dataset", "calibration"},
          {"cause", "none"},
          {"verdict", "adequate"},
          {"models", {{"base", stickslip::diagnosis::calibrated_json(m)},
                      {"extended", stickslip::diagnosis::calibrated_json(m)}}}};
}

TEST(ValidateCli, WritesTheSchemasJsonACsvPerRunAndReportsProgressUnlessQuiet) {
  stickslip::testing::CliSandbox box("stickslip-vcli");
  stickslip::measured::SynthOptions o;
  o.model = stickslip::engine::SimConfig::seed(stickslip::engine::model_kind<stickslip::engine::LuGre>, 0.0);
  stickslip::measured::MeasuredConditions c;
  c.t_on = 1.5;
  c.duration = 3.0;
  o.runs = {c, c};
  o.runs[1].va = 4e-3;
  o.rate = 500.0;
  o.noise_sigma = 0.02;
  o.offset = 0.05;
  o.rtol = 1e-8;
  const auto data = stickslip::measured::synthesize(o);
  const auto manifest = stickslip::measured::write_dataset(data, box.dir() / "data");
  box.write("diag.json", table1_diagnosis().dump());
  const auto r = box.run("validate diag.json '" + manifest.string() + "' --out out --quiet");
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  EXPECT_EQ(r.err, "");
  const json v = json::parse(stickslip::testing::slurp(box.dir() / "out" / "validation.json"));
  const stickslip::common::SchemaValidator schema(json::parse(stickslip::diagnosis::validation_schema_text()));
  const auto errors = schema.validate(v);
  EXPECT_TRUE(errors.empty()) << stickslip::common::to_string(errors);
  ASSERT_EQ(v["runs"].size(), 2u);
  for (const auto& run : v["runs"]) {
    EXPECT_LT(run["rmse_base"].get<double>(), 0.04) << run.dump().substr(0, 400);
    const std::string csv = stickslip::testing::slurp(box.dir() / "out" / run["csv"].get<std::string>());
    EXPECT_EQ(csv.substr(0, csv.find('\n')), "t,Fd_measured,Fd_base,Fd_extended");
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + static_cast<long>(data.runs[0].t.size()));
  }
  const auto loud = box.run("validate diag.json '" + manifest.string() + "' --out out2");
  ASSERT_EQ(loud.code, 0) << loud.err;
  EXPECT_NE(loud.err.find("[validation]"), std::string::npos) << loud.err;
  EXPECT_NE(loud.err.find("[done]"), std::string::npos) << loud.err;
  box.write("bad.json", R"({"cause": "none"})");
  const auto bad = box.run("validate bad.json '" + manifest.string() + "' --out out3");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("models"), std::string::npos) << bad.err;
}

}  // namespace
