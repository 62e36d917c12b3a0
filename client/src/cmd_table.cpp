// `stickslip table`: every registered friction model (or those given with --model) in the seed's
// two-stage run at v_a = 0, 0.2, 1.1 and 4 mm/s, per stage.
// Runs are independent; OpenMP spreads them across cores and results land in pre-sized storage
// indexed by run, so the output does not depend on the thread count.
#include <cstdio>
#include <iostream>
#include <vector>

#include "stickslip/client/cli.h"
#include "stickslip/engine/simulate.h"

namespace stickslip::client {
namespace {

struct TableArgs {
  std::string integrator = "adaptive";
  double dt = 1e-6;
  std::vector<std::string> models;  // empty: every registered model, in list order
};

int run_table(const TableArgs& a) {
  engine::IntegratorKind kind;
  try {
    kind = engine::integrator_from_string(a.integrator);
    engine::SimConfig probe;
    engine::set_parameter(probe, "dt", a.dt);
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip table: " << e.what() << "\n";
    return kBadInput;
  }
  std::vector<engine::ModelKind> models;
  for (const std::string& m : a.models) models.push_back(engine::model_from_string(m));
  if (models.empty()) models = engine::all_models();
  const double vas[] = {0.0, 0.2e-3, 1.1e-3, 4.0e-3};
  const int kRuns = static_cast<int>(models.size()) * 4;
  std::vector<engine::SimConfig> cfgs(kRuns);
  std::vector<engine::SimResult> results(kRuns);
  for (int i = 0; i < kRuns; ++i) {
    cfgs[i] = engine::SimConfig::seed(models[i / 4], vas[i % 4]);
    cfgs[i].integrator.kind = kind;
    cfgs[i].integrator.dt = a.dt;
  }
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < kRuns; ++i) results[i] = engine::simulate(cfgs[i]);  // simulate() never throws

  std::printf("Seed two-stage runs (10 s still base, then 10 s at v_a, f = 1500 Hz), integrator "
              "%s. Metrics over the last 60%% of each stage.\n",
              a.integrator.c_str());
  std::printf("%-17s %7s | %-31s | %-31s | %s\n", "model", "v_a", "stage 1: amp [N] raw  mean",
              "stage 2: amp [N] raw  mean", "slips 1/2  status");
  for (int i = 0; i < kRuns; ++i) {
    const engine::SimResult& r = results[i];
    std::printf("%-17s %4.1f mm/s", to_string(cfgs[i].model), vas[i % 4] * 1e3);
    for (std::size_t s = 0; s < 2; ++s) {
      if (s < r.stages.size())
        std::printf(" | %9.3f %7.3f %7.3f      ", r.stages[s].amplitude, r.stages[s].amplitude_raw,
                    r.stages[s].mean_force);
      else
        std::printf(" | %-31s", "  (not reached)");
    }
    const int s1 = r.stages.size() > 0 ? r.stages[0].slip_events : -1;
    const int s2 = r.stages.size() > 1 ? r.stages[1].slip_events : -1;
    std::printf(" | %4d/%-4d  %s%s%s\n", s1, s2, to_string(r.status), r.reason.empty() ? "" : ": ",
                r.reason.c_str());
  }
  for (const auto& r : results)
    if (r.status != engine::RunStatus::kOk) return kFailure;
  return kOk;
}

}  // namespace

void add_table_command(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<TableArgs>();
  CLI::App* cmd = app.add_subcommand(
      "table", "Print the per-stage table of the friction models at v_a = 0, 0.2, 1.1, 4 mm/s");
  cmd->add_option("--model", args->models, "a model to include, repeatable (default: all, " +
                                                engine::model_names() + ")")
      ->check(CLI::IsMember(model_ids()));
  cmd->add_option("--integrator", args->integrator, "rk4, rk4_event or adaptive")
      ->check(CLI::IsMember({"rk4", "rk4_event", "adaptive"}))
      ->capture_default_str();
  cmd->add_option("--dt", args->dt, "fixed step for rk4 [s]")->capture_default_str();
  cmd->callback([args, &exit_code] { exit_code = run_table(*args); });
}

}  // namespace stickslip::client
