// `stickslip diagnose MANIFEST --out DIR`: calibrate the four models on measured data, test
// every catalogue extension, name the cause (studies/include/stickslip/studies/diagnose.h).
#include <iostream>

#include "stickslip/client/cli.h"
#include "stickslip/studies/diagnose.h"

namespace stickslip::client {
namespace {

struct DiagnoseArgs {
  std::string manifest, out;
  std::vector<std::string> models;
  studies::DiagnoseOptions opt;
};

int run_diagnose(DiagnoseArgs& a) {
  studies::MeasuredDataset data;
  try {
    if (!a.models.empty()) {
      a.opt.models.clear();
      for (const auto& m : a.models) a.opt.models.push_back(model_from_string(m));
    }
    if (std::string why; !a.opt.IsValid(&why)) throw std::invalid_argument(why);
    data = studies::load_measured(a.manifest);
  } catch (const studies::MeasuredError& e) {
    std::cerr << "stickslip diagnose: " << e.what() << "\n";
    return kBadInput;
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip diagnose: " << e.what() << "\n";
    return kBadInput;
  }
  try {
    const studies::Diagnosis d = studies::diagnose(data, a.opt);
    const auto files = studies::write_report(d, a.out);
    std::cout << studies::summary_text(d);
    for (const auto& f : files) std::cout << "wrote " << f << "\n";
  } catch (const std::exception& e) {
    std::cerr << "stickslip diagnose: " << e.what() << "\n";
    return kFailure;
  }
  return kOk;
}

}  // namespace

void add_diagnose_command(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<DiagnoseArgs>();
  CLI::App* cmd = app.add_subcommand(
      "diagnose",
      "Calibrate the four models on a measured dataset, test every catalogue extension against "
      "the refitted base on held-out data, and name the cause (writes DIR/diagnosis.json and plots)");
  cmd->add_option("manifest", a->manifest, "measured-data manifest (JSON)")->required();
  cmd->add_option("--out", a->out, "output directory")->required();
  cmd->add_option("--models", a->models, "base models to calibrate (default: all four)");
  cmd->add_option("--fit-rate", a->opt.fit_rate, "decimated samples per second [Hz]")->capture_default_str();
  cmd->add_option("--holdout", a->opt.holdout_fraction, "held-out last part of each stage [-]")->capture_default_str();
  cmd->add_option("--alpha", a->opt.alpha, "family-wise significance level [-]")->capture_default_str();
  cmd->add_option("--min-gain", a->opt.min_gain, "minimum held-out gain to name a cause [-]")->capture_default_str();
  cmd->add_option("--threads", a->opt.threads, "OpenMP threads (0 = default)")->capture_default_str();
  cmd->callback([a, &exit_code] { exit_code = run_diagnose(*a); });
}

}  // namespace stickslip::client
