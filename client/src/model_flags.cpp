// Command-line flags of the friction models' parameters and options, derived from the model
// registry (engine/include/stickslip/engine/model_list.h): one flag per parameter, alias and
// option, with the unit, default and models in the help. Nothing here names a model.
#include <cstdio>

#include "stickslip/client/cli.h"
#include "stickslip/engine/registry.h"

namespace stickslip::client {
namespace {

std::string without_underscores(std::string_view name) {
  std::string out;
  for (const char c : name)
    if (c != '_') out += c;
  return out;
}

// "--kt,--k_t" for k_t, "--DV" for DV.
std::string flag_names_of(std::string_view name) {
  const std::string flag = without_underscores(name);
  std::string names = "--" + flag;
  if (flag != name) names += ",--" + std::string(name);
  return names;
}

// "Dahl, Reset Integrator, LuGre": the models with the parameter or option name.
std::string titles_with(std::string_view name) {
  std::string out;
  for (const engine::ModelKind m : engine::models_using(name))
    out += (out.empty() ? "" : ", ") + std::string(engine::model_traits(m).info->title);
  return out;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

std::string model_flag_names(std::string_view name) { return flag_names_of(name); }

std::vector<ModelFlag> model_flags() {
  std::vector<ModelFlag> out;
  for (const engine::ParamDef& p : engine::kFrictionParameters) {
    ModelFlag f;
    f.names = flag_names_of(p.name);
    if (p.alias != nullptr) f.names += "," + flag_names_of(p.alias);
    f.target = p.name;
    f.help = std::string(p.description) + " [" + engine::unit_of(p.dim) + "] (default " +
             number(p.def) + "; " + titles_with(p.name) + ")";
    out.push_back(std::move(f));
  }
  for (const engine::OptionDef& o : engine::kFrictionOptions) {
    ModelFlag f;
    f.names = flag_names_of(o.name);
    f.target = o.name;
    f.choices.assign(o.choices.begin(), o.choices.end());
    f.help = std::string(o.description) + " (default " +
             o.choices[static_cast<std::size_t>(o.def)] + "; " + titles_with(o.name) + ")";
    out.push_back(std::move(f));
  }
  return out;
}

std::vector<std::string> model_ids() {
  std::vector<std::string> out;
  for (const engine::ModelTraits& t : engine::all_model_traits()) out.push_back(t.info->name);
  return out;
}

CLI::Option* add_model_option(CLI::App& cmd, std::string& model) {
  std::string help = "friction model:";
  for (const engine::ModelTraits& t : engine::all_model_traits())
    help += std::string(" ") + t.info->name + " (" + t.info->title + "),";
  help.pop_back();
  return cmd.add_option("--model", model, help)
      ->check(CLI::IsMember(model_ids()))
      ->capture_default_str();
}

}  // namespace stickslip::client
