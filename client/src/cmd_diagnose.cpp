// `stickslip diagnose MANIFEST --out DIR`: calibrate the friction models on measured data, test
// every catalogue extension, name the cause (diagnosis/include/stickslip/diagnosis/diagnose.h).
// With --server URL the same diagnosis runs as a job on stickslipd (cmd_diagnosis_remote.cpp).
#include <iostream>

#include "diagnose_remote.h"
#include "progress_printer.h"
#include "stickslip/client/cli.h"
#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/engine/registry.h"

namespace stickslip::client {
namespace {

struct DiagnoseArgs {
  std::string manifest, out;
  std::vector<std::string> models, candidates;
  diagnosis::DiagnoseOptions opt;
  // --server
  std::string server, idempotency_key;
  bool wait = false, json_output = false;
  bool quiet = false;
};

int run_diagnose(DiagnoseArgs& a) {
  measured::MeasuredDataset data;
  try {
    if (a.out.empty()) throw std::invalid_argument("--out DIR is required (or --server URL)");
    if (!a.models.empty()) {
      a.opt.models.clear();
      for (const auto& m : a.models) a.opt.models.push_back(engine::model_from_string(m));
    }
    if (!a.candidates.empty()) {
      a.opt.candidates.clear();
      for (const auto& c : a.candidates) a.opt.candidates.push_back(engine::extension_from_string(c));
    }
    if (std::string why; !a.opt.IsValid(&why)) throw std::invalid_argument(why);
    data = measured::load_measured(a.manifest);
  } catch (const measured::MeasuredError& e) {
    std::cerr << "stickslip diagnose: " << e.what() << "\n";
    return kBadInput;
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip diagnose: " << e.what() << "\n";
    return kBadInput;
  }
  a.opt.progress = progress_printer(a.quiet, &a.opt.progress_interval);
  try {
    const diagnosis::Diagnosis d = diagnosis::diagnose(data, a.opt);
    const auto files = diagnosis::write_report(d, a.out);
    std::cout << diagnosis::summary_text(d);
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
      "Calibrate every base model on a measured dataset (scale-free, on the samples or on the "
      "statistics of the stick-slip), judge whether the best reproduces the record, test every "
      "catalogue extension against it on held-out data, and name the cause (writes "
      "DIR/diagnosis.json and plots); with --server, run it as a job on stickslipd");
  cmd->add_option("manifest", a->manifest, "measured-data manifest (JSON)")->required();
  cmd->add_option("--out", a->out, "output directory (with --server: written after --wait)");
  cmd->add_option("--models", a->models,
                  "base models to calibrate (default: all, " + engine::model_names() + ")");
  cmd->add_option("--candidates", a->candidates,
                  "catalogue extensions to test (default: all of them)");
  auto* fit_rate = cmd->add_option("--fit-rate", a->opt.fit_rate, "decimated samples per second [Hz]")->capture_default_str();
  auto* holdout = cmd->add_option("--holdout", a->opt.holdout_fraction, "held-out last part of each stage [-]")->capture_default_str();
  auto* alpha = cmd->add_option("--alpha", a->opt.alpha, "family-wise significance level [-]")->capture_default_str();
  auto* min_gain = cmd->add_option("--min-gain", a->opt.min_gain, "minimum held-out gain over the noise floor to name a cause [-]")->capture_default_str();
  auto* evals_base = cmd->add_option("--max-evals-base", a->opt.max_evals_base,
                                     "objective evaluations per base model")->capture_default_str();
  auto* evals_cand = cmd->add_option("--max-evals-candidate", a->opt.max_evals_candidate,
                                     "objective evaluations per extension")->capture_default_str();
  auto* whole_runs = cmd->add_flag("--whole-run-holdout,!--no-whole-run-holdout", a->opt.whole_run_holdout,
                                   "also hold out each whole run in turn (leave one v_a out; default on)");
  auto* evals_fold = cmd->add_option("--max-evals-fold", a->opt.max_evals_fold,
                                     "objective evaluations per left-out-run refit")->capture_default_str();
  cmd->add_option("--threads", a->opt.threads, "OpenMP threads (0 = default; local only)")->capture_default_str();
  cmd->add_flag("--quiet", a->quiet, "no progress on stderr (the phase, models or candidates, evaluations, time left)");
  cmd->add_option("--server", a->server,
                  "run on this stickslipd (token: $STICKSLIP_TOKEN): sends the manifest and its "
                  "CSVs, prints the diagnosis id");
  cmd->add_flag("--wait", a->wait, "with --server: wait for the result (exit 4 if it fails)");
  cmd->add_flag("--json", a->json_output, "with --server: the diagnosis resource as JSON");
  cmd->add_option("--idempotency-key", a->idempotency_key, "with --server: retry-safe key");
  cmd->callback([=, &exit_code] {
    if (a->server.empty()) {
      exit_code = run_diagnose(*a);
      return;
    }
    RemoteDiagnoseArgs r;
    r.server = a->server;
    r.manifest = a->manifest;
    r.out = a->out;
    r.wait = a->wait;
    r.json_output = a->json_output;
    r.idempotency_key = a->idempotency_key;
    r.options = nlohmann::json::object();
    if (!a->models.empty()) r.options["models"] = a->models;
    if (!a->candidates.empty()) r.options["candidates"] = a->candidates;
    if (fit_rate->count() > 0) r.options["fit_rate"] = a->opt.fit_rate;
    if (holdout->count() > 0) r.options["holdout_fraction"] = a->opt.holdout_fraction;
    if (alpha->count() > 0) r.options["alpha"] = a->opt.alpha;
    if (min_gain->count() > 0) r.options["min_gain"] = a->opt.min_gain;
    if (evals_base->count() > 0) r.options["max_evals_base"] = a->opt.max_evals_base;
    if (evals_cand->count() > 0) r.options["max_evals_candidate"] = a->opt.max_evals_candidate;
    if (whole_runs->count() > 0) r.options["whole_run_holdout"] = a->opt.whole_run_holdout;
    if (evals_fold->count() > 0) r.options["max_evals_fold"] = a->opt.max_evals_fold;
    exit_code = remote_diagnose(r);
  });
}

}  // namespace stickslip::client
