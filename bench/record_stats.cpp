// The model-free reading of a measured dataset (diagnosis/include/stickslip/diagnosis/detail/
// diagnose_record.h): per run its noise, spikes, initial state, scoring and the stick-slip
// statistics of every stage's fitted and held-out part. A table printer.
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "stickslip/diagnosis/detail/diagnose_record.h"
#include "stickslip/measured/measured.h"

using namespace stickslip;
using namespace stickslip::diagnosis;
using namespace stickslip::diagnosis::detail;

int main(int argc, char** argv) {
  std::string manifest = std::string(STICKSLIP_SOURCE_DIR) + "/../shared/data/colas2019/manifest.json";
  double holdout = 0.3;
  CLI::App app{"Model-free statistics of a measured dataset"};
  app.add_option("manifest", manifest, "measured-data manifest")->capture_default_str();
  app.add_option("--holdout", holdout, "held-out last part of each stage")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  const measured::MeasuredDataset d = measured::load_measured(manifest);
  for (const auto& run : d.runs) {
    const RecordInfo r = analyse_record(run, holdout);
    std::printf("%s: dt %.2g s, noise sigma %.3g N rho %.2f, spikes %zu (%.3f %%), preload %.4g N "
                "(%s, %s, slope %.3g N/s vs k_d v_d %.3g), level %.4g N\n  scoring: %s (%s)\n",
                r.name.c_str(), r.dt, r.noise.sigma, r.noise.rho, r.spikes,
                100.0 * r.spikes / r.y.size(), r.preload, r.from_rest ? "at rest" : "mid-experiment",
                r.stuck_at_start ? "stuck" : "sliding", r.start_slope,
                run.conditions.kd * run.conditions.vd, r.level,
                r.phase_locked ? "time_domain" : "statistics", r.why.c_str());
    for (const auto& w : r.windows) {
      const SlipStats& s = w.stats;
      std::printf("  stage %d %s [%.2f, %.2f) s: smooth %d, thr %.3g N | mean %.4g spread %.3g | "
                  "drops %d median %.3g [%.3g, %.3g] N, rate %.3g /s, interval %.3g s cv %.2f, "
                  "fall %.3f, ramp %.3f, creep %.3f, f_peak %.3g Hz, %s\n",
                  w.stage + 1, w.held ? "held" : "fit ", w.t0, w.t1, w.spec.smooth, w.spec.threshold,
                  s.mean, s.spread, s.drops, s.drop_median, s.drop_q25, s.drop_q75, s.rate,
                  s.interval_median, s.interval_cv, s.fall_fraction, s.ramp_slope, s.creep, s.f_peak,
                  to_string(s.regime));
    }
  }
  return 0;
}
