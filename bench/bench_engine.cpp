// Engine speed benchmarks (Google Benchmark).
//   BM_Rk4Speed/<model>:     fixed-step RK4 single trajectory, 0.5 s still + 0.5 s at
//                            v_a = 4 mm/s, dt = 1e-6; reports steps_per_s.
//   BM_AdaptiveSeed/<model>/<v_a um/s>: adaptive integrator, full 20 s seed run.
#include <benchmark/benchmark.h>

#include <cstddef>

#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"

namespace {

using stickslip::engine::IntegratorKind;
using stickslip::engine::ModelKind;
using stickslip::engine::RunStatus;
using stickslip::engine::SimConfig;

ModelKind model_of(int64_t i) { return static_cast<ModelKind>(i); }

// Runs cfg once per benchmark iteration; returns the total integrator steps.
double run_timed(benchmark::State& state, const SimConfig& cfg) {
  double total_steps = 0;
  for (auto _ : state) {
    auto r = stickslip::engine::simulate(cfg);
    if (r.status != RunStatus::kOk) {
      state.SkipWithError(r.reason.c_str());
      break;
    }
    total_steps += static_cast<double>(r.steps);
    benchmark::DoNotOptimize(r.x_end);
  }
  state.SetLabel(stickslip::engine::to_string(cfg.model));
  return total_steps;
}

void BM_Rk4Speed(benchmark::State& state) {
  const ModelKind model = model_of(state.range(0));
  SimConfig cfg = SimConfig::seed(model, 4e-3);
  cfg.stages[0].duration = 0.5;
  cfg.stages[1].duration = 0.5;
  cfg.integrator.kind = IntegratorKind::kRk4;
  cfg.integrator.dt = 1e-6;
  const double total_steps = run_timed(state, cfg);
  state.counters["steps_per_s"] = benchmark::Counter(total_steps, benchmark::Counter::kIsRate);
}

void BM_AdaptiveSeed(benchmark::State& state) {
  const ModelKind model = model_of(state.range(0));
  const double v_a = static_cast<double>(state.range(1)) * 1e-6;  // um/s -> m/s
  SimConfig cfg = SimConfig::seed(model, v_a);
  cfg.integrator.kind = IntegratorKind::kAdaptive;
  const double total_steps = run_timed(state, cfg);
  state.counters["steps"] =
      benchmark::Counter(total_steps, benchmark::Counter::kAvgIterations);
}

void Models(benchmark::internal::Benchmark* b) {
  for (int m = 0; m < 4; ++m) b->Arg(m);
}

void ModelsVa(benchmark::internal::Benchmark* b) {
  for (int m = 0; m < 4; ++m)
    for (int va : {0, 4000}) b->Args({m, va});
}

}  // namespace

BENCHMARK(BM_Rk4Speed)->Apply(Models)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_AdaptiveSeed)->Apply(ModelsVa)->Unit(benchmark::kMillisecond)->Iterations(1);

BENCHMARK_MAIN();
