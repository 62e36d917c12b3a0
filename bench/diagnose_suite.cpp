// The hidden-effect suite of issue 5 as a table printer (not a test): every case of
// hidden_effect_cases() over several seeds, diagnosed; prints one line per case and seed (named
// cause, held-out gain on time blocks and on whole runs held out, recovered size parameter) and
// the confusion table (true effect x named
// cause, counts over seeds).
//
//   diagnose_suite [--full | --seed-conditions] [--verbose] [--seeds N] [--first-seed K] [--case NAME]...
//   diagnose_suite --random [--family seed|short] [--seeds N] [--first-seed K] [--case PREFIX]...
//                  [--lugre-only] [--ranges]
//   --random: the randomised suite (random_cases in stickslip/diagnosis/diagnose_suite.h): every
//   catalogue effect and two nulls per seed, every drawn number printed; seeds K ... K + N - 1.
//   --full: the full datasets (3 runs x 7 s at 2 kHz, every base model); --seed-conditions: the
//   seed's conditions for every case (3 runs x 20 s, v_a = 0, 1.1, 4 mm/s, LuGre base);
//   default: the CI datasets (SuiteDatasets in stickslip/diagnosis/diagnose_suite.h).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "stickslip/engine/simulate.h"
#include "stickslip/diagnosis/diagnose_suite.h"
#include "stickslip/measured/synth.h"

using namespace stickslip;
using namespace stickslip::diagnosis;

namespace {

/// The confusion table under `title`: rows the hidden cases, columns the named causes.
void print_confusion(const std::string& title, const std::vector<std::string>& rows,
                     const std::vector<std::string>& causes,
                     std::map<std::string, std::map<std::string, int>>& table) {
  std::printf("\n%s\n", title.c_str());
  const char* abbrev[] = {"none", "visc", "strib", "dwell", "wavi", "drift", "load", "sensor", "damp", "vweak", "aging"};
  std::printf("| %-22s |", "case");
  for (const char* a : abbrev) std::printf(" %6s |", a);
  std::printf("\n|%s|", std::string(24, '-').c_str());
  for (std::size_t i = 0; i < causes.size(); ++i) std::printf("%s|", std::string(8, '-').c_str());
  std::printf("\n");
  for (const auto& r : rows) {
    std::printf("| %-22s |", r.c_str());
    for (const auto& k : causes) std::printf(" %6d |", table[r][k]);
    std::printf("\n");
  }
}

/// The randomised suite: one line per case (drawn numbers, named cause, recovered size, base fit
/// against the noise), the confusion table and the recovered parameters.
int random_suite(int first, int seeds, RandomFamily family, const std::vector<std::string>& only,
                 bool lugre_only, bool verbose) {
  std::vector<std::string> causes = {"none"};
  for (engine::ExtensionKind k : engine::extension_catalogue()) causes.push_back(to_string(k));
  std::map<std::string, std::map<std::string, int>> table;
  std::vector<std::string> rows;
  int passed = 0, total = 0, base_ok = 0, nulls = 0;
  double seconds = 0;
  for (int s = first; s < first + seeds; ++s) {
    for (const RandomCase& c : random_cases(static_cast<std::uint64_t>(s), family)) {
      const std::string row = c.name.substr(0, c.name.find('#'));
      bool wanted = only.empty();
      for (const auto& o : only) wanted = wanted || c.name.rfind(o, 0) == 0;
      if (!wanted) continue;
      if (std::find(rows.begin(), rows.end(), row) == rows.end()) rows.push_back(row);
      DiagnoseOptions o;
      if (lugre_only) o.models = {engine::model_kind<engine::LuGre>};
      o.whole_run_holdout = false;
      const Diagnosis d = diagnose(measured::synthesize(c.data), o);
      const HiddenVerdict v = judge(c, d);
      ++table[row][d.cause];
      ++total;
      passed += v.ok();
      seconds += d.seconds;
      double fit = 0, held = 0;
      for (const auto& cal : d.calibrations)
        if (cal.model == d.base_model) fit = cal.rmse_fit, held = cal.rmse_heldout;
      if (c.kind == engine::ExtensionKind::kNone) {
        ++nulls;
        base_ok += held <= 1.5 * c.data.noise_sigma;
      }
      std::printf("%-28s named %-22s %-8s %s %.4g (true %.4g) base %s fit %.4f held %.4f noise %.3f rho %.2f %.0f s %s\n",
                  c.name.c_str(), d.cause.c_str(), d.adequacy.verdict.c_str(), c.judged.c_str(), v.recovered,
                  v.truth, to_string(d.base_model), fit, held, c.data.noise_sigma, c.data.noise_rho, d.seconds,
                  v.ok() ? "ok" : "NO");
      if (verbose) {
        std::printf("  drawn:");
        for (const auto& [n, x] : c.drawn) std::printf(" %s=%.4g", n.c_str(), x);
        std::printf("\n%s", summary_text(d).c_str());
      }
      std::fflush(stdout);
    }
  }
  print_confusion("Confusion table (rows: hidden effect; columns: named cause; counts over seeds " +
                      std::to_string(first) + "-" + std::to_string(first + seeds - 1) + ")",
                  rows, causes, table);
  std::printf("\n%d of %d diagnoses met every requirement; base held-out RMSE within 1.5 x noise on %d of %d "
              "nulls; %.0f s diagnosing in all\n", passed, total, base_ok, nulls, seconds);
  return passed == total ? 0 : 1;
}

/// The cost of one fitting simulation per v_a and rtol (--time-sim).
void time_simulations() {
  for (double rtol : {1e-5, 1e-4, 1e-3})
    for (double va : {0.0, 1.5e-3, 5e-3}) {
      engine::SimConfig c = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, va);
      c.stages = {engine::Stage{3.5, 0.0, 1500}, engine::Stage{2.5, va, 1500}};
      c.integrator.rtol = c.integrator.atol = rtol;
      c.trace.rate = 4000;
      const auto t0 = std::chrono::steady_clock::now();
      const engine::SimResult r = engine::simulate(c);
      std::printf("rtol %g va %g: %.3f s, %zu trace samples\n", rtol, va,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                  r.trace.size());
    }
}

/// Every candidate of a diagnosis (--verbose): where each fit went.
void print_verbose(const diagnosis::Diagnosis& d) {
  std::printf("%s(%d model evaluations)\n", diagnosis::summary_text(d).c_str(), d.evaluations);
  // Refitted base parameters, fit RMSE and LR of every candidate: where a fit went.
  for (const auto& cand : d.candidates) {
    std::printf("  %-24s fit %.4f held %.4f lr %.1f p %.2g%s |", to_string(cand.kind),
                cand.rmse_fit, cand.rmse_heldout, cand.lr, cand.p_value,
                cand.at_base_point ? " (at base point)" : "");
    for (const auto& p : cand.base_params) std::printf(" %s=%.6g", p.name.c_str(), p.value);
    for (const auto& p : cand.params) std::printf(" %s=%.6g", p.name.c_str(), p.value);
    std::printf("\n");
  }
  for (const auto& cal : d.calibrations)
    if (cal.model == d.base_model)
      std::printf("  base fit %.4f held-out %.4f rho %.3f n %.0f n_eff %.0f\n", cal.rmse_fit,
                  cal.rmse_heldout, d.evidence.rho, d.evidence.n, d.evidence.n_eff);
}

}  // namespace

int main(int argc, char** argv) {
  diagnosis::SuiteDatasets family = diagnosis::SuiteDatasets::kCi;
  bool verbose = false;
  int seeds = 3, first = 0;  // seeds 1000 + first ... 1000 + first + seeds - 1
  std::vector<std::string> only;
  bool full = false, seed_conditions = false, time_sim = false;
  CLI::App app{"The hidden-effect suite as a table: named causes and the confusion table"};
  auto* full_flag = app.add_flag("--full", full, "the full datasets (3 runs x 7 s at 2 kHz, every base model)");
  app.add_flag("--seed-conditions", seed_conditions,
               "the seed's conditions for every case (3 runs x 20 s, LuGre base)")
      ->excludes(full_flag);
  app.add_flag("--verbose", verbose, "print every candidate of every diagnosis");
  app.add_flag("--time-sim", time_sim, "only time one fitting simulation per v_a and rtol");
  app.add_option("--seeds", seeds, "number of seeds")->type_name("N");
  app.add_option("--first-seed", first, "seeds 1000 + K ...")->type_name("K");
  app.add_option("--case", only, "only this case (repeatable)")->type_name("NAME");
  bool random = false, lugre_only = false, ranges = false;
  std::string random_family = "seed";
  app.add_flag("--random", random, "the randomised suite (issue 21 item 8)");
  app.add_option("--family", random_family, "with --random: seed (3 x 20 s) or short")->capture_default_str();
  app.add_flag("--lugre-only", lugre_only, "with --random: calibrate LuGre only (default: every model)");
  app.add_flag("--ranges", ranges, "print the randomised suite's ranges");
  CLI11_PARSE(app, argc, argv);
  if (ranges) {
    std::printf("%s", random_suite_ranges().c_str());
    return 0;
  }
  if (random)
    return random_suite(first, seeds, random_family == "short" ? RandomFamily::kShort : RandomFamily::kSeed, only,
                        lugre_only, verbose);
  if (full) family = diagnosis::SuiteDatasets::kFull;
  if (seed_conditions) family = diagnosis::SuiteDatasets::kSeed;
  if (time_sim) {
    time_simulations();
    return 0;
  }
  const auto cases = diagnosis::hidden_effect_cases();
  std::vector<std::string> causes = {"none"};
  for (engine::ExtensionKind k : engine::extension_catalogue()) causes.push_back(to_string(k));
  std::map<std::string, std::map<std::string, int>> table;
  std::vector<std::string> rows;
  int passed = 0, total = 0;
  double seconds = 0;
  // gain: on the held-out time blocks (judged); runs: on whole runs held out in turn (reported).
  std::printf("%-24s %4s %-24s %7s %7s %11s %11s %6s %5s\n", "case", "seed", "named", "gain",
              "runs", "true", "recovered", "t[s]", "ok");
  for (const auto& c : cases) {
    if (!only.empty() && std::find(only.begin(), only.end(), c.name) == only.end()) continue;
    rows.push_back(c.name);
    for (int s = first; s < first + seeds; ++s) {
      const diagnosis::Diagnosis d = diagnosis::diagnose(measured::synthesize(diagnosis::hidden_case_dataset(c, 1000 + s, family)),
                                   diagnosis::hidden_case_options(family));
      const diagnosis::HiddenVerdict v = diagnosis::judge(c, d);
      ++table[c.name][d.cause];
      ++total;
      passed += v.ok();
      seconds += d.seconds;
      std::printf("%-24s %4d %-24s %7.3f %7.3f %11.4g %11.4g %6.1f %5s\n", c.name.c_str(), s,
                  d.cause.c_str(), d.gain, d.gain_heldout_runs, v.truth, v.recovered, d.seconds,
                  v.ok() ? "yes" : "NO");
      if (verbose) print_verbose(d);
      std::fflush(stdout);
    }
  }
  print_confusion("Confusion table (rows: hidden case; columns: named cause; counts over " +
                      std::to_string(seeds) + " seeds)",
                  rows, causes, table);
  std::printf("\n%d of %d diagnoses met every requirement; %.0f s diagnosing in all\n", passed,
              total, seconds);
  return passed == total ? 0 : 1;
}
