// Diagnosis speed (issue 5): a 3-run dataset (3 x 20 s at 2 kHz; v_a = 0, 1.1, 4 mm/s from
// t_on = 10 s; LuGre with a hidden viscous term, 0.03 N noise) diagnosed with every base model
// and every catalogue candidate. Target: <= 3 minutes on the 2-core machine. Prints the time,
// the number of model evaluations and the summary. A table printer, not a timed test.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>

#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/measured/measured.h"
#include "stickslip/measured/synth.h"

using namespace stickslip;
using namespace stickslip::diagnosis;

int main(int argc, char** argv) {
  // --via-csv DIR: write the dataset as manifest + CSV files (9 significant digits) and diagnose
  // what loads back, as `stickslip synth` + `stickslip diagnose` do.
  std::string via_csv;
  CLI::App app{"Diagnosis speed on the seed's 3 x 20 s conditions"};
  app.add_option("--via-csv", via_csv, "write the dataset to DIR and diagnose what loads back")
      ->type_name("DIR");
  CLI11_PARSE(app, argc, argv);
  measured::SynthOptions o;
  o.model = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  o.model.extension.kind = engine::ExtensionKind::kViscous;
  o.model.extension.sigma2 = 30.0;
  for (double va : {0.0, 1.1e-3, 4e-3}) {
    measured::MeasuredConditions c;
    c.va = va;
    o.runs.push_back(c);
  }
  o.noise_sigma = 0.03;
  o.rate = 2000;
  o.rtol = 1e-8;
  const auto t0 = std::chrono::steady_clock::now();
  measured::MeasuredDataset data = measured::synthesize(o);
  if (!via_csv.empty()) data = measured::load_measured(measured::write_dataset(data, via_csv));
  const double t_synth = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const diagnosis::Diagnosis d = diagnosis::diagnose(data, diagnosis::DiagnoseOptions{});
  std::printf("synth: %.1f s; diagnose (3 x 20 s at 2 kHz, %zu models, %zu candidates): %.1f s "
              "wall, %d model evaluations (target <= 180 s)\n",
              t_synth, d.options.models.size(), d.options.candidates.size(), d.seconds,
              d.evaluations);
  std::cout << diagnosis::summary_text(d);
  // Where the evaluations went (the candidates run two at a time, the base models too).
  std::printf("evaluations:");
  for (const auto& c : d.calibrations) std::printf(" %s %d,", to_string(c.model), c.evals);
  for (const auto& c : d.candidates) std::printf(" %s %d,", to_string(c.kind), c.evals);
  int folds = 0;
  for (const auto& h : d.run_holdouts) folds += h.evals;
  std::printf(" whole-run folds %d\n", folds);
  return 0;
}
