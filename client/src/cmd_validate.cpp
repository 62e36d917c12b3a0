// `stickslip validate DIAGNOSIS.json MANIFEST --out DIR`: the calibrated models of a diagnosis
// predict the runs of a measured dataset with no refit (diagnosis/include/stickslip/diagnosis/
// validate.h): DIR/validation.json, DIR/<run>.csv (t, Fd_measured, Fd_base, Fd_extended) and a
// plot per run. With --server URL the same runs as a job on stickslipd (cmd_validate_remote.cpp).
#include <fstream>
#include <iostream>
#include <sstream>

#include "progress_printer.h"
#include "stickslip/client/cli.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/diagnosis/validate.h"
#include "validate_remote.h"

namespace stickslip::client {
namespace {

struct ValidateArgs {
  std::string diagnosis, manifest, out;
  diagnosis::ValidateOptions opt;
  bool quiet = false;
  RemoteValidateArgs remote;
};

nlohmann::json read_diagnosis(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument("cannot read diagnosis \"" + path + "\"");
  std::ostringstream ss;
  ss << in.rdbuf();
  std::vector<common::SpecError> errors;
  auto doc = common::parse_json(ss.str(), &errors);
  if (!doc) throw std::invalid_argument(path + ": " + common::to_string(errors));
  return *doc;
}

int run_validate(ValidateArgs& a) {
  nlohmann::json diag;
  measured::MeasuredDataset data;
  try {
    if (a.out.empty()) throw std::invalid_argument("--out DIR is required (or --server URL)");
    if (std::string why; !a.opt.IsValid(&why)) throw std::invalid_argument(why);
    diag = read_diagnosis(a.diagnosis);
    data = measured::load_measured(a.manifest);
  } catch (const std::exception& e) {
    std::cerr << "stickslip validate: " << e.what() << "\n";
    return kBadInput;
  }
  double interval = 0.5;
  a.opt.progress = progress_printer(a.quiet, &interval);
  try {
    const diagnosis::Validation v = diagnosis::validate(diag, data, a.opt);
    const auto files = diagnosis::write_validation(v, a.out);
    std::cout << diagnosis::summary_text(v);
    for (const auto& f : files) std::cout << "wrote " << f << "\n";
    for (const auto& r : v.runs)
      if (r.status != "ok") return kFailure;
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip validate: " << e.what() << "\n";
    return kBadInput;
  } catch (const std::exception& e) {
    std::cerr << "stickslip validate: " << e.what() << "\n";
    return kFailure;
  }
  return kOk;
}

}  // namespace

void add_validate_command(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<ValidateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "validate",
      "Predict the runs of a measured dataset with the calibrated models of a diagnosis, with no "
      "refit: measured against predicted stick-slip statistics per run (DIR/validation.json), the "
      "predicted series at the measured sample times (DIR/<run>.csv) and a plot per run; with "
      "--server, run it as a job on stickslipd");
  cmd->add_option("diagnosis", a->diagnosis, "diagnosis.json written by stickslip diagnose")->required();
  cmd->add_option("manifest", a->manifest, "measured-data manifest (JSON) of the runs to predict")->required();
  cmd->add_option("--out", a->out, "output directory (with --server: written after --wait)");
  cmd->add_option("--rtol", a->opt.rtol, "engine accuracy (rtol = atol [N])")->capture_default_str();
  cmd->add_option("--threads", a->opt.threads, "OpenMP threads over the runs (0 = default; local only)")
      ->capture_default_str();
  cmd->add_flag("--quiet", a->quiet, "no progress on stderr");
  cmd->add_option("--server", a->remote.server, "run on this stickslipd (token: $STICKSLIP_TOKEN)");
  cmd->add_flag("--wait", a->remote.wait, "with --server: wait for the result (exit 4 if it fails)");
  cmd->add_flag("--json", a->remote.json_output, "with --server: the validation resource as JSON");
  cmd->add_option("--idempotency-key", a->remote.idempotency_key, "with --server: retry-safe key");
  cmd->callback([=, &exit_code] {
    if (a->remote.server.empty()) {
      exit_code = run_validate(*a);
      return;
    }
    a->remote.diagnosis = a->diagnosis;
    a->remote.manifest = a->manifest;
    a->remote.out = a->out;
    a->remote.quiet = a->quiet;
    exit_code = remote_validate(a->remote);
  });
}

}  // namespace stickslip::client
