// Speed of the friction models added for issue 20 (elasto-plastic, rate-and-state, GMS) at the
// seed's conditions: the full two-stage run (10 s still + 10 s at v_a, 1500 Hz), for each model
// and v_a in {0, 0.2, 1.1, 4} mm/s. The reference is the model's own adaptive integrator at
// rtol = atol = 1e-10 [N] with dt_max = 1e-5 s (cached with --ref-cache); each row is a run at
// rtol (atol = rtol [N]), timed as the thread CPU time of the fastest of --reps repetitions,
// with its F_d RMS error on the 2 kHz trace against the reference, relative to the model's force
// scale F_ref (force_scale(): max(F_S, F_C), or F_N mu0 for rate-and-state). "<=1e-4" marks the
// rows that reach 1e-4 of F_ref; the target is such a row in <= 0.2 s on one core.
//
// Usage: bench_models [--only MODEL[:V_A_MM_S]] [--ref-cache DIR] [--reps N]
//                     [--rtols A,B,...] [--dt-max S]
// Run on one core: OMP_NUM_THREADS=1 taskset -c 1 build/bench/bench_models --ref-cache /tmp/bm
// (the references run on up to 2 threads the first time: ~1-2 min).
#include <omp.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"

namespace {

using namespace stickslip::engine;

constexpr double kTraceRate = 2000.0;

struct Case {
  ModelKind model;
  double v_a;  // [m/s]
};

SimConfig make_cfg(const Case& c, double rtol, double dt_max) {
  SimConfig cfg = SimConfig::seed(c.model, c.v_a);
  cfg.integrator.kind = IntegratorKind::kAdaptive;
  cfg.integrator.rtol = cfg.integrator.atol = rtol;
  cfg.integrator.dt_max = dt_max;
  cfg.trace.rate = kTraceRate;
  return cfg;
}

double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// The reference F_d trace of a case: from the cache when there, else computed (and cached).
std::vector<double> reference(const Case& c, const std::string& cache_dir, std::string* status) {
  char name[160];
  std::snprintf(name, sizeof name, "/bm_%s_%g.bin", to_string(c.model), c.v_a * 1e3);
  const std::string path = cache_dir.empty() ? std::string() : cache_dir + name;
  std::vector<double> F;
  if (!path.empty()) {
    std::ifstream in(path, std::ios::binary);
    std::size_t n = 0;
    if (in.read(reinterpret_cast<char*>(&n), sizeof n)) {
      F.resize(n);
      if (in.read(reinterpret_cast<char*>(F.data()), static_cast<std::streamsize>(n * sizeof(double)))) {
        *status = "cached";
        return F;
      }
    }
  }
  const SimResult r = simulate(make_cfg(c, 1e-10, 1e-5));
  if (r.status != RunStatus::kOk) {
    *status = "reference " + std::string(to_string(r.status)) + ": " + r.reason;
    return {};
  }
  for (const TraceSample& s : r.trace) F.push_back(s.F_d);
  *status = "computed, " + std::to_string(r.steps) + " steps";
  if (!path.empty()) {
    std::ofstream out(path, std::ios::binary);
    const std::size_t n = F.size();
    out.write(reinterpret_cast<const char*>(&n), sizeof n);
    out.write(reinterpret_cast<const char*>(F.data()), static_cast<std::streamsize>(n * sizeof(double)));
  }
  return F;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Speed of the issue-20 friction models at the seed's conditions"};
  std::string only, cache_dir;
  int reps = 3;
  std::vector<double> rtols = {1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 1e-6};
  double dt_max = IntegratorOptions{}.dt_max;
  app.add_option("--only", only, "run only this model (and v_a in mm/s), e.g. rate_state:4");
  app.add_option("--ref-cache", cache_dir, "store/load the reference traces in DIR");
  app.add_option("--reps", reps, "time each run N times and report the fastest")->check(CLI::PositiveNumber);
  app.add_option("--rtols", rtols, "rtol values (atol = rtol [N])")->delimiter(',');
  app.add_option("--dt-max", dt_max, "largest adaptive step [s]")->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  std::vector<Case> cases;
  for (ModelKind m : {model_kind<ElastoPlastic>, model_kind<RateState>, model_kind<Gms>})
    for (double v_a : {0.0, 0.2e-3, 1.1e-3, 4e-3}) {
      char key[64];
      std::snprintf(key, sizeof key, "%s:%g", to_string(m), v_a * 1e3);
      if (only.empty() || only == to_string(m) || only == key) cases.push_back({m, v_a});
    }
  if (cases.empty()) {
    std::fprintf(stderr, "--only %s: no such model/v_a (models: elasto_plastic, rate_state, "
                         "gms; v_a: 0, 0.2, 1.1, 4)\n", only.c_str());
    return 2;
  }
  std::vector<std::vector<double>> refs(cases.size());
  std::vector<std::string> ref_status(cases.size());
  const int ref_threads = std::min(2, omp_get_max_threads());
#pragma omp parallel for schedule(dynamic) num_threads(ref_threads)
  for (std::size_t i = 0; i < cases.size(); ++i)
    refs[i] = reference(cases[i], cache_dir, &ref_status[i]);

  std::printf("# bench_models: the seed's 10 s + 10 s run; reference rtol 1e-10, dt_max 1e-5; "
              "trace %g Hz; dt_max %g s; cpu: fastest of %d\n", kTraceRate, dt_max, reps);
  std::printf("%-15s %9s %8s %9s %9s %9s %9s %12s %10s %s\n", "model", "v_a[mm/s]", "rtol",
              "steps", "rejected", "switches", "cpu[s]", "F_d_RMS[N]", "/F_ref", "");
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const Case& c = cases[i];
    if (refs[i].empty()) {
      std::printf("%-15s %9.1f %s\n", to_string(c.model), c.v_a * 1e3, ref_status[i].c_str());
      continue;
    }
    const double f_ref = force_scale(make_cfg(c, 1e-7, dt_max));
    double best_ok = HUGE_VAL;
    for (double rtol : rtols) {
      const SimConfig cfg = make_cfg(c, rtol, dt_max);
      SimResult r;
      double cpu = HUGE_VAL;
      for (int k = 0; k < reps; ++k) {
        const double t0 = thread_cpu_seconds();
        r = simulate(cfg);
        cpu = std::min(cpu, thread_cpu_seconds() - t0);
      }
      double err = std::nan("");
      // Common samples (a run may lack the sample at its very end: t = 20 s vs 40000 periods of
      // the trace by round-off).
      const std::size_t n = std::min(r.trace.size(), refs[i].size());
      if (r.status == RunStatus::kOk && n + 1 >= refs[i].size()) {
        double sum = 0;
        for (std::size_t k = 0; k < n; ++k) sum += std::pow(r.trace[k].F_d - refs[i][k], 2);
        err = std::sqrt(sum / static_cast<double>(n));
      }
      const bool ok = err <= 1e-4 * f_ref;
      if (ok) best_ok = std::min(best_ok, cpu);
      std::printf("%-15s %9.1f %8.0e %9zu %9zu %9zu %9.3f %12.3e %10.2e %s%s\n",
                  to_string(c.model), c.v_a * 1e3, rtol, r.steps, r.rejected, r.switches, cpu,
                  err, err / f_ref, ok ? "<=1e-4" : "", r.status == RunStatus::kOk ? "" :
                  (" " + std::string(to_string(r.status)) + ": " + r.reason).c_str());
    }
    std::printf("# %s at %g mm/s: fastest to 1e-4 of F_ref = %.4g N: %s (reference %s)\n",
                to_string(c.model), c.v_a * 1e3, f_ref,
                std::isfinite(best_ok) ? (std::to_string(best_ok) + " s").c_str() : "none",
                ref_status[i].c_str());
  }
  return 0;
}
