// Sensitivity benchmark (a table printer, not a test; run it on an idle machine):
//   1. runs/s of the issue's Sobol study: LuGre two-stage run at the seed's conditions (Table 1;
//      v_a = 1.1 mm/s, f = 1500 Hz), stages shortened to 4 s + 4 s as the nightly report does,
//      d = 8 parameters (F_S, F_C, k_t, v_s, h_t, k_d, m, v_d at +-20 %), N = 4096: 40,960 runs.
//      v_a and f stay fixed, so the study allows the batched engine (rk4, dt = 1e-6 s, SIMD
//      lanes); measured side by side with the nightly's adaptive integrator on the first
//      --rows base rows (the design's first rows: a prefix of the N = 4096 design), and
//      projected to 40,960 runs. --full runs all 40,960 with the batched engine.
//   2. the estimators at N = 4096, d = 8 with 1000 bootstrap resamples, per output: Sobol S1/ST,
//      with second order (N (2d + 2) design), the convergence over N = 16 .. 4096, and the
//      given-data methods (RBD-FAST, delta, PAWN) on the 8192 A and B points. Timed on the real
//      outputs with --full, else on a stand-in output of the same size (the Sobol G function; the
//      estimators' cost does not depend on the values).
// Usage: sensitivity_bench [--rows K] [--threads T] [--full] [--skip-runs]
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include "stickslip/studies/runner.h"
#include "stickslip/studies/sa_given.h"
#include "stickslip/studies/sa_sobol.h"

namespace {

namespace fs = std::filesystem;
namespace ss = stickslip::studies::sensitivity;
using namespace stickslip::studies;
using stickslip::store::Store;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The issue's study: seed values +-20 %, v_a and f fixed at Fig. 8's conditions.
std::string spec_text(std::size_t n, const std::string& integrator) {
  return R"({"name": "bench-sobol-lugre-d8", "base": {"model": "lugre"},
    "stages": [{"duration": 4}, {"duration": 4, "v_a": 0.0011, "f": 1500}],
    "integrator": )" + integrator + R"(, "F_S_below_F_C": "raise_F_S_to_F_C",
    "design": {"type": "sobol", "n": )" + std::to_string(n) + R"(, "seed": 1, "ranges": [
      {"name": "F_S", "min": 8.88, "max": 13.32}, {"name": "F_C", "min": 6.64, "max": 9.96},
      {"name": "k_t", "min": 57054400.0, "max": 85581600.0},
      {"name": "v_s", "min": 0.00028, "max": 0.00042},
      {"name": "h_t", "min": 11016.0, "max": 16524.0}, {"name": "k_d", "min": 9360.0, "max": 14040.0},
      {"name": "m", "min": 0.532, "max": 0.798}, {"name": "v_d", "min": 0.0008, "max": 0.0012}]}})";
}

StudySpec parse_or_die(const std::string& text) {
  ParseResult r = parse_study(text, Limits{50000});
  if (!r.ok()) {
    std::fprintf(stderr, "spec does not parse: %s\n", to_string(r.errors).c_str());
    std::exit(1);
  }
  return std::move(*r.spec);
}

struct Ran {
  RunSummary summary;
  std::vector<std::vector<double>> outputs;  ///< [output][run]: stage 1, 2 amplitude, mean force
};

Ran run_fresh(const fs::path& db, const StudySpec& spec, int threads) {
  fs::remove(db);
  Ran ran;
  std::string id;
  {
    Store store = Store::open(db);
    id = create_or_find_study(store, spec).id;
  }
  RunnerOptions opt;
  opt.threads = threads;
  ran.summary = run_study(db, id, spec, opt);
  Store store = Store::open(db, Store::Mode::kReadOnly);
  ran.outputs.assign(4, std::vector<double>(spec.run_count(), 0.0));
  for (std::int64_t after = -1;;) {
    const auto page = store.get_runs(id, after, 4000);
    if (page.empty()) break;
    for (const auto& r : page) {
      after = r.design_index;
      for (std::size_t s = 0; s < r.stages.size() && s < 2; ++s) {
        ran.outputs[2 * s][static_cast<std::size_t>(r.design_index)] = r.stages[s].amplitude;
        ran.outputs[2 * s + 1][static_cast<std::size_t>(r.design_index)] = r.stages[s].mean_force;
      }
    }
  }
  return ran;
}

void time_runs(const fs::path& tmp, std::size_t rows, int threads) {
  std::printf("== runs: LuGre 4 s + 4 s, d = 8, first %zu base rows = %zu runs per integrator, "
              "%d threads\n", rows, rows * 10, threads);
  const char* integrators[][2] = {{"rk4 dt=1e-6 (batched)", R"({"kind": "rk4", "dt": 1e-6})"},
                                  {"adaptive (nightly)", R"({"kind": "adaptive"})"}};
  for (const auto& [label, json] : integrators) {
    const Ran r = run_fresh(tmp / "runs.db", parse_or_die(spec_text(rows, json)), threads);
    const double rate = static_cast<double>(r.summary.computed) / r.summary.wall_s;
    std::printf("  %-24s %6lld runs in %7.1f s: %6.2f runs/s (%lld batched, %lld failed); "
                "40,960 runs would take %.0f min\n",
                label, static_cast<long long>(r.summary.computed), r.summary.wall_s, rate,
                static_cast<long long>(r.summary.batched), static_cast<long long>(r.summary.failed),
                40960.0 / rate / 60.0);
  }
}

void time_estimators(const std::vector<std::vector<double>>& outputs, const char* what) {
  constexpr std::size_t n = 4096, d = 8;
  std::printf("== estimators, N = %zu, d = %zu, 1000 resamples, on %s\n", n, d, what);
  ss::BootstrapOptions opt;  // 1000 resamples, 95 %
  const ss::SaltelliShape first{n, d, false, ss::SaltelliLayout::kBlocks};
  ss::SaltelliShape second{n, d, true, ss::SaltelliLayout::kRows};
  const ss::Matrix x2 = ss::saltelli_rows(second, 1);
  const auto g = [](const std::vector<double>& u) {
    return ss::sobol_g(u, {0, 0.5, 1, 2, 4, 9, 19, 99});
  };
  std::vector<double> y2;
  for (const auto& row : x2) y2.push_back(g(row));
  const ss::Matrix x1 = ss::saltelli_rows(first, 1);
  ss::Matrix ab(x1.begin(), x1.begin() + 2 * n);  // the A and B rows: given data
  auto timed = [](const char* label, const std::function<void()>& f) {
    const auto t0 = Clock::now();
    f();
    std::printf("  %-44s %8.3f s\n", label, since(t0));
  };
  for (std::size_t o = 0; o < outputs.size(); ++o) {
    const std::vector<double>& y = outputs[o];
    const std::vector<double> yab(y.begin(), y.begin() + 2 * n);
    std::printf(" output %zu\n", o + 1);
    timed("sobol S1, ST", [&] { ss::sobol_analysis(y, first, opt); });
    timed("sobol S1, ST, S2 (stand-in, 73,728 rows)", [&] { ss::sobol_analysis(y2, second, opt); });
    timed("sobol convergence, 9 prefixes", [&] { ss::sobol_convergence(y, first, opt); });
    timed("rbd-fast, 8192 points", [&] { ss::rbd_fast_analysis(ab, yab, opt); });
    timed("delta, 8192 points", [&] { ss::delta_analysis(ab, yab, opt); });
    timed("pawn, 8192 points", [&] { ss::pawn_analysis(ab, yab, opt); });
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t rows = 32;
  int threads = 2;
  bool full = false, runs = true;
  CLI::App app{"Sensitivity benchmark: runs/s of the issue's Sobol study, the estimators' time"};
  app.add_option("--rows", rows, "base rows of the design timed with both integrators")
      ->capture_default_str();
  app.add_option("--threads", threads, "OpenMP threads of the runs")->capture_default_str();
  app.add_flag("--full", full, "run all 40,960 runs (batched) and time the estimators on them");
  app.add_flag("!--skip-runs", runs, "skip the runs/s comparison");
  CLI11_PARSE(app, argc, argv);
  const fs::path tmp = fs::temp_directory_path() / ("stickslip-sa-bench-" + std::to_string(getpid()));
  fs::create_directories(tmp);
  if (runs) time_runs(tmp, rows, threads);
  if (full) {
    const auto t0 = Clock::now();
    Ran r = run_fresh(tmp / "full.db", parse_or_die(spec_text(4096, R"({"kind": "rk4", "dt": 1e-6})")), threads);
    std::printf("== full study: %lld runs in %.1f s (%.2f runs/s, %lld batched, %lld failed)\n",
                static_cast<long long>(r.summary.computed), since(t0),
                static_cast<double>(r.summary.computed) / since(t0),
                static_cast<long long>(r.summary.batched), static_cast<long long>(r.summary.failed));
    time_estimators(r.outputs, "the study's outputs (stage 1/2 amplitude, mean force)");
  } else {
    const ss::Matrix x = ss::saltelli_design(4096, 8, 1);
    std::vector<double> y;
    for (const auto& row : x) y.push_back(ss::sobol_g(row, {0, 0.5, 1, 2, 4, 9, 19, 99}));
    time_estimators({y}, "a stand-in output (Sobol G)");
  }
  fs::remove_all(tmp);
  return 0;
}
