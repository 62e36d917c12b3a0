// `stickslip synth`: a synthetic measured dataset (manifest + CSVs) from any model with any
// catalogue effect (measured/include/stickslip/measured/synth.h).
#include <cstdlib>
#include <iostream>

#include "stickslip/client/cli.h"
#include "stickslip/common/text.h"
#include "stickslip/measured/synth.h"

namespace stickslip::client {
namespace {

struct SynthArgs {
  std::string model = engine::to_string(engine::SimConfig{}.model);  // the engine's default
  std::vector<std::string> params;  // NAME=VALUE engine parameters
  std::string effect = "none";
  std::vector<std::string> effect_params;
  std::vector<double> va = {0.0, 1.1e-3, 4e-3};
  measured::MeasuredConditions cond;
  measured::SynthOptions opt;
  std::string out;
};

double parse_number(const std::string& field, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size())
    throw engine::InvalidParameter(field, text, "not a number");
  return v;
}

int run_synth(SynthArgs& a) {
  measured::SynthOptions o = a.opt;
  try {
    o.model = engine::SimConfig::seed(engine::model_from_string(a.model), 0.0);
    for (const std::string& p : a.params) {
      const auto eq = p.find('=');
      if (eq == std::string::npos || eq == 0)
        throw engine::InvalidParameter("param", p, "expected NAME=VALUE, e.g. F_S=10.5");
      engine::set_parameter(o.model, p.substr(0, eq), parse_number(p.substr(0, eq), p.substr(eq + 1)));
    }
    apply_effect_options(a.effect, a.effect_params, o.model);
    o.runs.clear();
    for (double va : a.va) {
      measured::MeasuredConditions c = a.cond;
      c.va = va;
      o.runs.push_back(c);
    }
    std::vector<std::string> errors;
    if (!o.IsValid(&errors)) throw std::invalid_argument(common::join(errors, "; "));
    engine::SimConfig probe = o.model;
    measured::apply_conditions(o.runs[0], probe);
    if (!probe.IsValid(&errors)) throw std::invalid_argument(errors.front());
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip synth: " << e.what() << "\n";
    return kBadInput;
  }
  try {
    const auto data = measured::synthesize(o);
    const auto manifest = measured::write_dataset(data, a.out);
    std::cout << manifest.string() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "stickslip synth: " << e.what() << "\n";
    return kFailure;
  }
  return kOk;
}

}  // namespace

void add_synth_command(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<SynthArgs>();
  CLI::App* cmd = app.add_subcommand(
      "synth",
      "Write a synthetic measured dataset (manifest.json + one CSV per --va) from any model "
      "with any catalogue effect, at converged accuracy, with noise and an offset");
  add_model_option(*cmd, a->model);
  cmd->add_option("--param", a->params,
                  "engine parameter NAME=VALUE (SI; e.g. F_S=10.5, v_s=4e-4), repeatable");
  add_effect_options(*cmd, a->effect, a->effect_params);
  cmd->add_option("--noise", a->opt.noise_sigma, "noise standard deviation [N]")
      ->capture_default_str();
  cmd->add_option("--noise-ar", a->opt.noise_rho, "AR(1) noise coefficient [-] (0 = white)")
      ->capture_default_str();
  cmd->add_option("--rate", a->opt.rate, "sampling rate [Hz]")->capture_default_str();
  cmd->add_option("--offset", a->opt.offset, "constant sensor offset [N]")->capture_default_str();
  cmd->add_option("--seed", a->opt.seed, "noise seed")->capture_default_str();
  cmd->add_option("--rtol", a->opt.rtol, "engine accuracy (adaptive rtol and atol)")
      ->capture_default_str();
  cmd->add_option("--va", a->va, "base velocity amplitude of each run after t_on [m/s]")
      ->capture_default_str();
  cmd->add_option("--m", a->cond.m, "body mass [kg]")->capture_default_str();
  cmd->add_option("--kd", a->cond.kd, "drive stiffness [N/m]")->capture_default_str();
  cmd->add_option("--vd", a->cond.vd, "drive velocity [m/s]")->capture_default_str();
  cmd->add_option("--f", a->cond.f, "base frequency [Hz]")->capture_default_str();
  cmd->add_option("--t-on", a->cond.t_on, "vibration starts [s]")->capture_default_str();
  cmd->add_option("--duration", a->cond.duration, "run length [s]")->capture_default_str();
  cmd->add_option("--name", a->opt.name, "dataset name")->capture_default_str();
  cmd->add_option("--out", a->out, "output directory")->required();
  cmd->callback([a, &exit_code] { exit_code = run_synth(*a); });
}

}  // namespace stickslip::client
