// `stickslip simulate`: one run, JSON summary on stdout, optional CSV trace.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <optional>

#include "stickslip/client/cli.h"
#include "stickslip/engine/simulate.h"

namespace stickslip::client {
namespace {

struct SimulateArgs {
  std::string model = engine::to_string(engine::SimConfig{}.model);  // the engine's default
  std::string integrator = "adaptive";
  std::string trace_file;
  double trace_rate = 2000.0;
  std::string effect = "none";
  std::vector<std::string> effect_params;  // "name=value"
  std::map<std::string, std::optional<double>> values;  // parameter name -> value if given
  std::map<std::string, std::optional<std::string>> options;  // model option -> choice if given
};

// Options that map one-to-one onto engine parameter names (flag, parameter, help): the drive, the
// stages, the integrator and the metrics. The friction models' parameters and options come from
// the registry (model_flags()).
struct Flag {
  const char* flag;
  const char* param;
  const char* help;
};
constexpr Flag kFlags[] = {
    {"--m", "m", "body mass [kg] (0.665)"},
    {"--kd", "k_d", "drive stiffness [N/m] (11700)"},
    {"--vd", "v_d", "drive velocity [m/s] (1e-3)"},
    {"--Fz", "F_z", "external normal load [N], F_N = F_z + m g (29.4)"},
    {"--va", "v_a", "base velocity amplitude after t_on [m/s] (0)"},
    {"--f", "f", "base vibration frequency [Hz] (1500)"},
    {"--t-on", "t_on", "time the base starts vibrating [s] (10)"},
    {"--duration", "duration", "whole run [s] (20)"},
    {"--dt", "dt", "rk4 step / adaptive initial step [s] (1e-6)"},
    {"--rtol", "rtol", "adaptive relative tolerance [-] (1e-7)"},
    {"--atol", "atol", "adaptive absolute tolerance [N] (1e-7)"},
    {"--dt-max", "dt_max", "adaptive largest step [s] (1e-4)"},
    {"--settle-fraction", "settle_fraction", "metrics skip this start fraction of a stage (0.4)"},
    {"--cycle-threshold", "cycle_threshold", "smallest F_d drop counted as a slip [N] (0.2)"},
};

// A friction parameter or option given for a model that does not have it (--model lugre --a_rs
// 0.02) is an error naming the flag, its value and the models that have it, not a silent no-op.
// Empty when the model has it (or the name is not a friction parameter: t_on, k_d ...).
std::string not_of_model(engine::ModelKind m, const std::string& name) {
  const std::vector<engine::ModelKind> users = engine::models_using(name);
  if (users.empty() || std::find(users.begin(), users.end(), m) != users.end()) return {};
  std::string which;
  for (const engine::ModelKind u : users)
    which += (which.empty() ? "" : ", ") + std::string(engine::model_traits(u).info->name);
  return std::string("is not a parameter of model ") + engine::model_traits(m).info->name +
         " (models with it: " + which + ")";
}

int run_simulate(SimulateArgs& a) {
  engine::SimConfig cfg;
  try {
    const engine::ModelKind model = engine::model_from_string(a.model);
    for (auto& [name, v] : a.values)
      if (const std::string why = not_of_model(model, name); v && !why.empty())
        throw engine::InvalidParameter(name, *v, why);
    for (auto& [name, choice] : a.options)
      if (const std::string why = not_of_model(model, name); choice && !why.empty())
        throw engine::InvalidParameter(name, *choice, why);
    cfg = engine::SimConfig::seed(model, 0.0);
    cfg.integrator.kind = engine::integrator_from_string(a.integrator);
    // Order matters for derived settings: t_on before duration, then everything else.
    for (const char* first : {"t_on", "duration"})
      if (auto& v = a.values[first]) engine::set_parameter(cfg, first, *v);
    for (auto& [name, v] : a.values)
      if (v && name != "t_on" && name != "duration") engine::set_parameter(cfg, name, *v);
    for (auto& [name, choice] : a.options)
      if (choice) engine::set_option(cfg, name, *choice);
    apply_effect_options(a.effect, a.effect_params, cfg);
    if (!a.trace_file.empty()) {
      if (!(std::isfinite(a.trace_rate) && a.trace_rate > 0))
        throw engine::InvalidParameter("trace-rate", a.trace_rate, "must be a finite number > 0");
      cfg.trace.rate = a.trace_rate;
    }
    cfg.Validate();
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip simulate: " << e.what() << "\n";
    return kBadInput;
  }
  const engine::SimResult r = engine::simulate(cfg);
  std::cout << summary_json(cfg, r) << "\n";
  if (!a.trace_file.empty()) {
    try {
      engine::write_trace_csv(r.trace, a.trace_file);
    } catch (const std::exception& e) {
      std::cerr << "stickslip simulate: " << e.what() << "\n";
      return kFailure;
    }
  }
  return r.status == engine::RunStatus::kOk ? kOk : kFailure;
}

}  // namespace

void add_simulate_command(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Run one simulation (default: the seed's 10 s still base then 10 s at --va) and print a "
      "JSON summary with per-stage metrics");
  add_model_option(*cmd, args->model);
  cmd->add_option("--integrator", args->integrator,
                  "rk4 (seed's fixed-step ode4), rk4_event (fixed step, located switches), "
                  "adaptive (ours)")
      ->check(CLI::IsMember({"rk4", "rk4_event", "adaptive"}))
      ->capture_default_str();
  for (const Flag& f : kFlags) cmd->add_option(f.flag, args->values[f.param], f.help);
  for (const ModelFlag& f : model_flags()) {
    if (f.choices.empty())
      cmd->add_option(f.names, args->values[f.target], f.help);
    else
      cmd->add_option(f.names, args->options[f.target], f.help)->check(CLI::IsMember(f.choices));
  }
  add_effect_options(*cmd, args->effect, args->effect_params);
  cmd->add_option("--trace", args->trace_file, "write a decimated CSV trace t,F_d,F_f,x,v,s");
  cmd->add_option("--trace-rate", args->trace_rate, "trace samples per second [Hz]")
      ->capture_default_str();
  cmd->callback([args, &exit_code] { exit_code = run_simulate(*args); });
}

}  // namespace stickslip::client
