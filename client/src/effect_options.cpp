// --effect / --effect-param: the catalogue extensions (engine/include/stickslip/engine/extensions.h)
// on the command line.
#include <cmath>
#include <cstdlib>

#include "stickslip/client/cli.h"
#include "stickslip/engine/extensions.h"

namespace stickslip::client {

namespace {

/// "none, viscous, ...": the catalogue's ids.
std::string effect_ids() {
  std::string out = "none";
  for (const engine::ExtensionKind k : engine::extension_catalogue())
    out += std::string(", ") + engine::to_string(k);
  return out;
}

/// "sigma2, stribeck_delta, ...": every extension parameter name.
std::string effect_parameter_names() {
  std::string out;
  for (const std::string& n : engine::all_extension_parameter_names())
    out += (out.empty() ? "" : ", ") + n;
  return out;
}

}  // namespace

void add_effect_options(CLI::App& cmd, std::string& effect, std::vector<std::string>& params) {
  cmd.add_option("--effect", effect, "catalogue extension: " + effect_ids())
      ->capture_default_str();
  cmd.add_option("--effect-param", params,
                 "extension parameter NAME=VALUE (SI), repeatable: sigma2 [N s/m], "
                 "stribeck_delta [-], dwell_A [N], dwell_tau [s], dwell_v [m/s], waviness_eps [-], "
                 "waviness_lambda [m], waviness_phi [rad], drift_gamma [1/m], load_eta [-], "
                 "load_phi [rad], sensor_tau [s] (or sensor_omega_n [rad/s]), sensor_zeta [-], "
                 "c_d [N s/m], vw_beta [-], vw_v [m/s], aging_beta [-], aging_Dc [m], aging_t0 [s]");
}

void apply_effect_options(const std::string& effect, const std::vector<std::string>& params,
                          engine::SimConfig& cfg) {
  engine::set_extension(cfg, effect);
  for (const std::string& p : params) {
    const auto eq = p.find('=');
    if (eq == std::string::npos || eq == 0)
      throw engine::InvalidParameter("effect-param", p, "expected NAME=VALUE, e.g. sigma2=50");
    const std::string name = p.substr(0, eq), text = p.substr(eq + 1);
    if (engine::extension_of_parameter(name) == engine::ExtensionKind::kNone)
      throw engine::InvalidParameter("effect-param", name,
                             "not an extension parameter; expected one of " +
                                 effect_parameter_names());
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size())
      throw engine::InvalidParameter(name, text, "not a number");
    engine::set_parameter(cfg, name, v);
  }
}

}  // namespace stickslip::client
