// Work-precision table: F_d RMS error vs wall time for fixed-step RK4 and the adaptive
// integrator, per model, for the seed's still-base run (v_a = 0) and the v_a = 4 mm/s run.
// The reference is event-locating RK4 (Karnopp, Reset Integrator) or plain RK4 (Dahl, LuGre)
// at dt = 1e-7; errors are compared on the 2 kHz trace (identical sample times across runs).
// Columns: accepted steps, rejected steps (adaptive), located switches, wall time of one
// single-threaded run (run pinned, e.g. taskset -c 0, on a quiet machine).
//
// Usage: work_precision [--quick]   (--quick: 2 s + 2 s runs, reference dt = 5e-7)
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"

namespace {

using namespace stickslip;

constexpr double kTraceRate = 2000.0;

struct Case {
  ModelKind model;
  double v_a;
};

SimConfig make_cfg(const Case& c, double stage_dur) {
  SimConfig cfg = SimConfig::seed(c.model, c.v_a);
  cfg.stages[0].duration = stage_dur;
  cfg.stages[1].duration = stage_dur;
  cfg.trace.rate = kTraceRate;
  return cfg;
}

// RMS of F_d difference over common samples; NaN if the run did not finish or times mismatch.
double rms_error(const SimResult& ref, const SimResult& r) {
  if (r.status != RunStatus::kOk || ref.status != RunStatus::kOk) return std::nan("");
  const std::size_t n = std::min(ref.trace.size(), r.trace.size());
  if (n == 0) return std::nan("");
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (std::abs(ref.trace[i].t - r.trace[i].t) > 1e-9) return std::nan("");
    const double d = r.trace[i].F_d - ref.trace[i].F_d;
    sum += d * d;
  }
  return std::sqrt(sum / static_cast<double>(n));
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else {
      std::fprintf(stderr, "usage: %s [--quick]\n", argv[0]);
      return 2;
    }
  }
  const double stage_dur = quick ? 2.0 : 10.0;
  const double ref_dt = quick ? 5e-7 : 1e-7;

  std::vector<Case> cases;
  for (ModelKind m : {ModelKind::kDahl, ModelKind::kKarnopp, ModelKind::kResetIntegrator,
                      ModelKind::kLuGre})
    for (double v_a : {0.0, 4e-3}) cases.push_back({m, v_a});

  // References, in parallel over the cases.
  std::vector<SimResult> refs(cases.size());
  std::vector<double> ref_wall(cases.size(), 0.0);
  std::fprintf(stderr, "computing %zu references at dt = %g on %d threads...\n", cases.size(),
               ref_dt, omp_get_max_threads());
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < static_cast<int>(cases.size()); ++i) {
    SimConfig cfg = make_cfg(cases[i], stage_dur);
    const bool event = cases[i].model == ModelKind::kKarnopp ||
                       cases[i].model == ModelKind::kResetIntegrator;
    cfg.integrator.kind = event ? IntegratorKind::kRk4Event : IntegratorKind::kRk4;
    cfg.integrator.dt = ref_dt;
    const auto t0 = std::chrono::steady_clock::now();
    refs[i] = simulate(cfg);
    ref_wall[i] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  std::printf("# work-precision: %s runs (%g s + %g s), reference dt = %g, trace %g Hz\n",
              quick ? "quick" : "full", stage_dur, stage_dur, ref_dt, kTraceRate);
  std::printf("%-17s %8s %-10s %-12s %11s %9s %9s %9s %16s %s\n", "model", "v_a[mm/s]",
              "integrator", "setting", "steps", "rejected", "switches", "wall[s]",
              "F_d_RMS_err[N]", "status");

  auto row = [](const Case& c, const char* integ, const std::string& setting,
                const SimResult& r, double wall, double err) {
    char errbuf[32];
    if (std::isnan(err))
      std::snprintf(errbuf, sizeof errbuf, "-");
    else
      std::snprintf(errbuf, sizeof errbuf, "%.3e", err);
    std::printf("%-17s %8.1f %-10s %-12s %11zu %9zu %9zu %9.3f %16s %s\n", to_string(c.model),
                c.v_a * 1e3, integ, setting.c_str(), r.steps, r.rejected, r.switches, wall,
                errbuf, to_string(r.status));
    std::fflush(stdout);
  };
  // Times one single-threaded run of cfg and prints its row against the reference.
  auto timed_row = [&row](const Case& c, const char* integ, const char* knob, double value,
                          const SimConfig& cfg, const SimResult& ref) {
    const auto t0 = std::chrono::steady_clock::now();
    const SimResult r = simulate(cfg);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    char s[32];
    std::snprintf(s, sizeof s, "%s=%g", knob, value);
    row(c, integ, s, r, wall, rms_error(ref, r));
  };

  for (std::size_t i = 0; i < cases.size(); ++i) {
    const Case& c = cases[i];
    const SimResult& ref = refs[i];
    {
      char s[32];
      std::snprintf(s, sizeof s, "dt=%g", ref_dt);
      const bool event = c.model == ModelKind::kKarnopp || c.model == ModelKind::kResetIntegrator;
      row(c, event ? "ref_rk4ev" : "ref_rk4", s, ref, ref_wall[i], std::nan(""));
    }
    for (double dt : {4e-6, 2e-6, 1e-6}) {
      SimConfig cfg = make_cfg(c, stage_dur);
      cfg.integrator.kind = IntegratorKind::kRk4;
      cfg.integrator.dt = dt;
      timed_row(c, "rk4", "dt", dt, cfg, ref);
    }
    for (double rtol : {1e-5, 1e-6, 1e-7, 1e-8}) {
      SimConfig cfg = make_cfg(c, stage_dur);
      cfg.integrator.kind = IntegratorKind::kAdaptive;
      cfg.integrator.rtol = rtol;
      cfg.integrator.atol = rtol * 10.0;
      timed_row(c, "adaptive", "rtol", rtol, cfg, ref);
    }
  }
  return 0;
}
