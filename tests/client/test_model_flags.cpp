// `stickslip simulate` offers one flag per friction parameter, alias and model option of the
// registry (engine/include/stickslip/engine/model_list.h), with unit, default and models in the
// help, and each flag sets its parameter; the flag spellings of the seed's parameters stay.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>

#include "stickslip/client/cli.h"
#include "stickslip/engine/registry.h"
#include "support/cli_process.h"

namespace stickslip::client {
namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// A model whose table has the parameter.
const char* model_with(std::string_view param) {
  for (const engine::ModelTraits& t : engine::all_model_traits())
    for (const engine::ParamDef& p : t.params)
      if (param == p.name) return t.info->name;
  return nullptr;
}

TEST(ModelFlags, OnePerParameterAndOptionWithUnitDefaultAndModels) {
  const auto flags = model_flags();
  ASSERT_EQ(flags.size(), engine::kFrictionParameters.size() + engine::kFrictionOptions.size());
  std::set<std::string> all_names;
  for (std::size_t i = 0; i < engine::kFrictionParameters.size(); ++i) {
    const engine::ParamDef& p = engine::kFrictionParameters[i];
    const ModelFlag& f = flags[i];
    EXPECT_EQ(f.target, p.name);
    EXPECT_TRUE(f.choices.empty());
    EXPECT_TRUE(contains(f.names, model_flag_names(p.name))) << f.names;
    if (p.alias != nullptr) {
      EXPECT_TRUE(contains(f.names, model_flag_names(p.alias))) << f.names;
    }
    EXPECT_TRUE(contains(f.help, std::string("[").append(engine::unit_of(p.dim)).append("]")))
        << f.help;
    EXPECT_TRUE(contains(f.help, "default ")) << f.help;
    EXPECT_TRUE(contains(f.help, engine::model_traits(engine::model_from_string(model_with(p.name)))
                                     .info->title))
        << f.help;
  }
  for (std::size_t i = 0; i < engine::kFrictionOptions.size(); ++i) {
    const ModelFlag& f = flags[engine::kFrictionParameters.size() + i];
    EXPECT_EQ(f.target, engine::kFrictionOptions[i].name);
    EXPECT_EQ(f.choices.size(), engine::kFrictionOptions[i].choices.size());
  }
  // No two flags share a name (CLI11 would refuse to start).
  for (const ModelFlag& f : flags) {
    std::string rest = f.names;
    for (std::size_t at; !rest.empty(); rest = at == std::string::npos ? "" : rest.substr(at + 1)) {
      at = rest.find(',');
      EXPECT_TRUE(all_names.insert(rest.substr(0, at)).second) << rest.substr(0, at);
    }
  }
}

TEST(ModelFlags, TheFlagIsTheNameWithoutUnderscoresPlusTheNameItself) {
  EXPECT_EQ(model_flag_names("k_t"), "--kt,--k_t");
  EXPECT_EQ(model_flag_names("F_slip"), "--Fslip,--F_slip");
  EXPECT_EQ(model_flag_names("DV"), "--DV");
}

class SimulateCli : public ::testing::Test {
 protected:
  stickslip::testing::CliSandbox box_{"stickslip-flags"};
};

TEST_F(SimulateCli, HelpListsEveryFlagAndTheSeedSpellingsStay) {
  const auto r = box_.run("simulate --help");
  ASSERT_EQ(r.code, 0) << r.err;
  for (const ModelFlag& f : model_flags()) EXPECT_TRUE(contains(r.out, f.names)) << f.names;
  for (const char* flag : {"--kt", "--kappa", "--FC", "--FS", "--DV", "--beta", "--s0", "--alpha",
                           "--ht", "--hv", "--vs"})
    EXPECT_TRUE(contains(r.out, std::string(flag) + ",") || contains(r.out, std::string(flag) + " "))
        << flag;
}

// Each flag reaches its parameter: a NaN is refused naming the parameter (exit 2), a valid
// value runs.
TEST_F(SimulateCli, EveryParameterFlagSetsItsParameter) {
  for (const ModelFlag& f : model_flags()) {
    if (!f.choices.empty()) continue;
    const std::string flag = f.names.substr(0, f.names.find(','));
    const std::string model = model_with(f.target);
    const auto bad = box_.run("simulate --model " + model + " " + flag + " nan --t-on 0.005 --duration 0.01");
    EXPECT_EQ(bad.code, 2) << flag << ": " << bad.err;
    EXPECT_TRUE(contains(bad.err, f.target + " = ")) << flag << ": " << bad.err;
  }
  const auto ok = box_.run("simulate --model karnopp --F_slip 8 --FS 9 --duration 0.5 --t-on 0.25");
  EXPECT_EQ(ok.code, 0) << ok.err;
}

// A parameter or option of another model is refused (exit 2), naming the flag's parameter, the
// model and a model that has it; it is not silently ignored.
TEST_F(SimulateCli, AParameterOfAnotherModelIsRefusedNamingIt) {
  for (const ModelFlag& f : model_flags()) {
    const std::string flag = f.names.substr(0, f.names.find(','));
    const std::string value = f.choices.empty() ? "0.02" : f.choices.front();
    for (const engine::ModelTraits& t : engine::all_model_traits()) {
      const auto users = engine::models_using(f.target);
      if (std::find(users.begin(), users.end(), t.kind) != users.end()) continue;
      const auto r = box_.run("simulate --model " + std::string(t.info->name) + " " + flag + " " +
                              value + " --t-on 0.005 --duration 0.01");
      EXPECT_EQ(r.code, 2) << t.info->name << " " << flag << ": " << r.err;
      EXPECT_TRUE(contains(r.err, f.target)) << r.err;
      EXPECT_TRUE(contains(r.err, std::string("not a parameter of model ") + t.info->name)) << r.err;
      EXPECT_TRUE(contains(r.err, engine::model_traits(users.front()).info->name)) << r.err;
      break;  // one model without it per flag keeps the test short
    }
  }
}

}  // namespace
}  // namespace stickslip::client
