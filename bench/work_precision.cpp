// Work-precision table: F_d RMS error vs wall time for fixed-step RK4 and the adaptive
// integrator, per model, for the seed's still-base run (v_a = 0) and the v_a = 4 mm/s run.
// The reference is event-locating RK4 (Karnopp, Reset Integrator) or plain RK4 (Dahl, LuGre)
// at dt = 1e-7; errors are compared on the 2 kHz trace (identical sample times across runs).
// Columns: accepted steps, rejected steps (adaptive), located switches, wall time of one
// single-threaded run (run pinned, e.g. taskset -c 0, on a quiet machine).
//
// Usage: work_precision [--quick] [--only MODEL[:V_A_MM_S]] [--ref-cache DIR] [--reps N] [--no-rk4]
//                       [--rtols A,B,...]
//   --quick      2 s + 2 s runs, reference dt = 5e-7
//   --only       run only this model (and v_a in mm/s), e.g. --only lugre:4
//   --ref-cache  store/load the reference traces in DIR (a reference takes ~30 s)
//   --reps       time each run N times and report the fastest (shared machine)
//   --no-rk4     skip the fixed-step RK4 rows (adaptive only)
//   --rtols      comma-separated rtol values of the adaptive rows (atol = 10 rtol [N])
//   --dt-max     largest adaptive step [s] (default: IntegratorOptions' 1e-4)
// The cpu[s] column is the thread CPU time of the fastest repetition, which is less sensitive
// than wall time to other load on the machine.
#include <omp.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"

namespace {

using namespace stickslip::engine;

constexpr double kTraceRate = 2000.0;

// Switching models have a hybrid form: their reference is rk4_event (located switches).
bool switching(ModelKind m) { return model_traits(m).info->model_class == ModelClass::kSwitching; }

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

double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::string cache_path(const std::string& dir, const Case& c, double stage_dur, double ref_dt) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "/wp_%s_%g_%g_%g.bin", to_string(c.model), c.v_a * 1e3,
                stage_dur, ref_dt);
  return dir + buf;
}

// Reference traces are cached as raw TraceSample arrays (plus steps/switches).
bool load_ref(const std::string& path, SimResult* r) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::size_t n = 0;
  in.read(reinterpret_cast<char*>(&n), sizeof n);
  in.read(reinterpret_cast<char*>(&r->steps), sizeof r->steps);
  in.read(reinterpret_cast<char*>(&r->switches), sizeof r->switches);
  r->trace.resize(n);
  in.read(reinterpret_cast<char*>(r->trace.data()),
          static_cast<std::streamsize>(n * sizeof(TraceSample)));
  return static_cast<bool>(in);
}

void save_ref(const std::string& path, const SimResult& r) {
  std::ofstream out(path, std::ios::binary);
  const std::size_t n = r.trace.size();
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  out.write(reinterpret_cast<const char*>(&r.steps), sizeof r.steps);
  out.write(reinterpret_cast<const char*>(&r.switches), sizeof r.switches);
  out.write(reinterpret_cast<const char*>(r.trace.data()),
            static_cast<std::streamsize>(n * sizeof(TraceSample)));
}


struct Options {
  bool quick = false;
  std::string only, cache_dir;
  int reps = 1;
  bool rk4_rows = true;
  std::vector<double> rtols = {1e-4, 1e-5, 1e-6, 1e-7, 1e-8};
  double dt_max = 0.0;  // 0: the IntegratorOptions default
  double stage_dur() const { return quick ? 2.0 : 10.0; }
  double ref_dt() const { return quick ? 5e-7 : 1e-7; }
};

void add_options(CLI::App& app, Options& o) {
  app.add_flag("--quick", o.quick, "2 s + 2 s runs, reference dt = 5e-7");
  app.add_option("--only", o.only, "run only this model (and v_a in mm/s), e.g. lugre:4")
      ->type_name("MODEL[:V_A_MM_S]");
  app.add_option("--ref-cache", o.cache_dir, "store/load the reference traces in DIR")
      ->type_name("DIR");
  app.add_option("--reps", o.reps, "time each run N times and report the fastest")
      ->type_name("N");
  app.add_flag("!--no-rk4", o.rk4_rows, "skip the fixed-step RK4 rows (adaptive only)");
  app.add_option("--rtols", o.rtols, "rtol values of the adaptive rows (atol = 10 rtol [N])")
      ->delimiter(',')
      ->type_name("A,B,...");
  app.add_option("--dt-max", o.dt_max, "largest adaptive step [s] (default: IntegratorOptions')")
      ->type_name("S");
}

/// Every registered model at v_a = 0 and 4 mm/s, or the one --only names.
std::vector<Case> select_cases(const std::string& only) {
  std::vector<Case> cases;
  for (ModelKind m : all_models())
    for (double v_a : {0.0, 4e-3}) {
      if (!only.empty()) {
        const std::string name = to_string(m);
        const auto colon = only.find(':');
        if (only.substr(0, colon) != name) continue;
        if (colon != std::string::npos && std::atof(only.c_str() + colon + 1) * 1e-3 != v_a)
          continue;
      }
      cases.push_back({m, v_a});
    }
  return cases;
}

/// The fine fixed-step references, in parallel over the cases (from the cache when given).
void compute_references(const Options& o, const std::vector<Case>& cases,
                        std::vector<SimResult>& refs, std::vector<double>& ref_wall) {
  refs.assign(cases.size(), SimResult{});
  ref_wall.assign(cases.size(), 0.0);
  std::fprintf(stderr, "computing %zu references at dt = %g on %d threads...\n", cases.size(),
               o.ref_dt(), omp_get_max_threads());
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < static_cast<int>(cases.size()); ++i) {
    SimConfig cfg = make_cfg(cases[i], o.stage_dur());
    const bool event = switching(cases[i].model);
    cfg.integrator.kind = event ? IntegratorKind::kRk4Event : IntegratorKind::kRk4;
    cfg.integrator.dt = o.ref_dt();
    const std::string path = o.cache_dir.empty()
                                 ? std::string()
                                 : cache_path(o.cache_dir, cases[i], o.stage_dur(), o.ref_dt());
    if (!path.empty() && load_ref(path, &refs[i])) continue;
    const auto t0 = std::chrono::steady_clock::now();
    refs[i] = simulate(cfg);
    ref_wall[i] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!path.empty() && refs[i].status == RunStatus::kOk) save_ref(path, refs[i]);
  }
}

void print_row(const Case& c, const char* integ, const std::string& setting, const SimResult& r,
               double wall, double cpu, double err) {
  char errbuf[32];
  if (std::isnan(err))
    std::snprintf(errbuf, sizeof errbuf, "-");
  else
    std::snprintf(errbuf, sizeof errbuf, "%.3e", err);
  std::printf("%-17s %8.1f %-10s %-12s %11zu %9zu %9zu %9.3f %9.3f %16s %s\n",
              to_string(c.model), c.v_a * 1e3, integ, setting.c_str(), r.steps, r.rejected,
              r.switches, wall, cpu, errbuf, to_string(r.status));
  std::fflush(stdout);
}

/// Times one single-threaded run of cfg (fastest of reps) and prints its row against ref.
void timed_row(const Case& c, const char* integ, const char* knob, double value,
               const SimConfig& cfg, const SimResult& ref, int reps) {
  SimResult r;
  double wall = 1e300, cpu = 1e300;
  for (int k = 0; k < reps; ++k) {
    const double c0 = thread_cpu_seconds();
    const auto t0 = std::chrono::steady_clock::now();
    r = simulate(cfg);
    wall = std::min(wall,
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    cpu = std::min(cpu, thread_cpu_seconds() - c0);
  }
  char s[32];
  std::snprintf(s, sizeof s, "%s=%g", knob, value);
  print_row(c, integ, s, r, wall, cpu, rms_error(ref, r));
}

/// The reference row, the rk4 rows and the adaptive rows of one case.
void case_rows(const Options& o, const Case& c, const SimResult& ref, double ref_wall) {
  {
    char s[32];
    std::snprintf(s, sizeof s, "dt=%g", o.ref_dt());
    const bool event = switching(c.model);
    print_row(c, event ? "ref_rk4ev" : "ref_rk4", s, ref, ref_wall, std::nan(""), std::nan(""));
  }
  for (double dt : {4e-6, 2e-6, 1e-6}) {
    if (!o.rk4_rows) break;
    SimConfig cfg = make_cfg(c, o.stage_dur());
    cfg.integrator.kind = IntegratorKind::kRk4;
    cfg.integrator.dt = dt;
    timed_row(c, "rk4", "dt", dt, cfg, ref, o.reps);
  }
  for (double rtol : o.rtols) {
    SimConfig cfg = make_cfg(c, o.stage_dur());
    cfg.integrator.kind = IntegratorKind::kAdaptive;
    cfg.integrator.rtol = rtol;
    cfg.integrator.atol = rtol * 10.0;
    if (o.dt_max > 0) cfg.integrator.dt_max = o.dt_max;
    timed_row(c, "adaptive", "rtol", rtol, cfg, ref, o.reps);
  }
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"Work-precision table of the engine's integrators"};
  add_options(app, o);
  CLI11_PARSE(app, argc, argv);
  o.reps = std::max(1, o.reps);

  const std::vector<Case> cases = select_cases(o.only);
  if (cases.empty()) {
    std::fprintf(stderr, "--only %s: no such model/v_a (models: %s; v_a: 0 or 4)\n",
                 o.only.c_str(), model_names().c_str());
    return 2;
  }
  std::vector<SimResult> refs;
  std::vector<double> ref_wall;
  compute_references(o, cases, refs, ref_wall);

  std::printf("# work-precision: %s runs (%g s + %g s), reference dt = %g, trace %g Hz\n",
              o.quick ? "quick" : "full", o.stage_dur(), o.stage_dur(), o.ref_dt(), kTraceRate);
  std::printf("%-17s %8s %-10s %-12s %11s %9s %9s %9s %9s %16s %s\n", "model", "v_a[mm/s]",
              "integrator", "setting", "steps", "rejected", "switches", "wall[s]", "cpu[s]",
              "F_d_RMS_err[N]", "status");
  for (std::size_t i = 0; i < cases.size(); ++i) case_rows(o, cases[i], refs[i], ref_wall[i]);
  return 0;
}
