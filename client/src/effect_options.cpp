// --effect / --effect-param: the catalogue extensions (engine/include/stickslip/engine/extensions.h)
// on the command line.
#include <cmath>
#include <cstdlib>

#include "stickslip/client/cli.h"
#include "stickslip/engine/extensions.h"

namespace stickslip::client {

void add_effect_options(CLI::App& cmd, std::string& effect, std::vector<std::string>& params) {
  cmd.add_option("--effect", effect,
                 "catalogue extension: none, viscous, stribeck_shape, dwell_time, waviness, "
                 "drift, normal_load_modulation, sensor_dynamics, drive_damping")
      ->capture_default_str();
  cmd.add_option("--effect-param", params,
                 "extension parameter NAME=VALUE (SI), repeatable: sigma2 [N s/m], "
                 "stribeck_delta [-], dwell_A [N], dwell_tau [s], dwell_v [m/s], waviness_eps [-], "
                 "waviness_lambda [m], waviness_phi [rad], drift_gamma [1/m], load_eta [-], "
                 "load_phi [rad], sensor_tau [s] (or sensor_omega_n [rad/s]), sensor_zeta [-], "
                 "c_d [N s/m]");
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
                             "not an extension parameter; expected one of sigma2, "
                             "stribeck_delta, dwell_A, dwell_tau, dwell_v, waviness_eps, "
                             "waviness_lambda, waviness_phi, drift_gamma, load_eta, load_phi, "
                             "sensor_tau, sensor_omega_n, sensor_zeta, c_d");
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size())
      throw engine::InvalidParameter(name, text, "not a number");
    engine::set_parameter(cfg, name, v);
  }
}

}  // namespace stickslip::client
