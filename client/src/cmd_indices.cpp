// `stickslip indices`: sensitivity indices of a stored study with a sampled design (indices.h).
#include <iostream>

#include "local_store.h"
#include "stickslip/client/cli.h"
#include "stickslip/studies/indices.h"

namespace stickslip::client {
namespace {

struct IndicesArgs {
  std::string study, db, out = "-";
  std::vector<std::string> outputs;
  bool json_out = false;
  studies::IndicesOptions options;
};

int print_indices(const IndicesArgs& a) {
  store::Store store = open_existing(a.db);
  const store::StudyRecord s = resolve_study(store, a.study);
  const studies::StudyIndices r = studies::compute_indices(store, s.id, a.outputs, a.options);
  write_output(a.out, a.json_out ? studies::indices_to_json(r).dump(2) + "\n"
                                 : studies::indices_to_table(r));
  if (!r.complete()) {
    std::cerr << "stickslip indices: some outputs have invalid indices (failed or missing runs, "
                 "or an output not defined at some point; see above)\n";
    return kStudyFailed;
  }
  return kOk;
}

}  // namespace

void add_indices_command(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<IndicesArgs>();
  CLI::App* cmd = app.add_subcommand(
      "indices",
      "Sensitivity indices of a stored study with bootstrap intervals: sobol (S1, ST, S2), efast, "
      "rbd_fast, dgsm, morris designs with their own method; delta, pawn, rbd_fast from the "
      "points of sobol, random, lhs or rbd_fast designs (--method). Constant outputs are "
      "reported undefined. Exit 0 when no output is invalid, 4 when one is because a run failed "
      "or is missing (the reason is printed), 2 for bad input");
  cmd->add_option("study", a->study, "study id or name (newest of that name)")->required();
  add_db_option(cmd, a->db);
  cmd->add_option("--output", a->outputs,
                  "output(s): stage<k>.amplitude, stage<k>.mean_force, stage<k>.period, "
                  "reduction_ratio, or y (analytic models); default: all of them");
  cmd->add_option("--method", a->options.method,
                  "sobol, efast, rbd_fast, dgsm, morris (the design's own, default), or the "
                  "given-data methods delta, pawn, rbd_fast");
  cmd->add_option("--seed", a->options.seed, "bootstrap seed")->capture_default_str();
  cmd->add_flag("--keep-resamples", a->options.keep_resamples,
                "include every bootstrap replicate in the JSON (<index>_resamples)");
  cmd->add_flag("--convergence", a->options.convergence,
                "sobol: also the indices on the prefixes N = 16, 32, ... of the design (JSON)");
  cmd->add_flag("--json", a->json_out, "print JSON instead of a table");
  cmd->add_option("--confidence", a->options.confidence, "bootstrap interval level")
      ->check(CLI::Range(0.5, 0.999))
      ->capture_default_str();
  cmd->add_option("--resamples", a->options.resamples, "bootstrap resamples")
      ->check(CLI::Range(10, 100000))
      ->capture_default_str();
  cmd->add_option("--out", a->out, "output file, - for stdout")->capture_default_str();
  cmd->callback([a, &exit_code] {
    exit_code = guarded("indices", [&] { return print_indices(*a); });
  });
}

}  // namespace stickslip::client
