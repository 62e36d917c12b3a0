// Batched RK4 speed (Google Benchmark): trajectory-steps per second per core, batched vs single.
//   BM_Batch/<model>/<lanes>: simulate_batch() on <lanes> trajectories with different friction
//                             and drive parameters, 0.1 s still + 0.1 s at v_a = 4 mm/s,
//                             dt = 1e-6 s (2e5 steps per trajectory).
//   BM_Single/<model>:        simulate() with rk4 on the same configuration, one trajectory.
// Counter traj_steps_per_s = trajectories x steps / CPU time. Run pinned to one core, e.g.
//   taskset -c 0 build/bench/bench_batch --benchmark_repetitions=3
#include <benchmark/benchmark.h>

#include <vector>

#include "stickslip/engine/batch.h"
#include "stickslip/engine/simulate.h"

namespace {

using namespace stickslip::engine;

SimConfig lane_cfg(ModelKind m, int i) {
  SimConfig c = SimConfig::seed(m, 4e-3);
  c.stages[0].duration = 0.1;
  c.stages[1].duration = 0.1;
  c.integrator.kind = IntegratorKind::kRk4;
  c.integrator.dt = 1e-6;
  c.friction["F_S"] = 11.1 - 0.01 * (i % 50);
  c.drive.k_d = 11700.0 * (1.0 + 0.001 * i);
  return c;
}

void BM_Batch(benchmark::State& state) {
  const auto model = static_cast<ModelKind>(state.range(0));
  const int lanes = static_cast<int>(state.range(1));
  std::vector<SimConfig> cfgs;
  for (int i = 0; i < lanes; ++i) cfgs.push_back(lane_cfg(model, i));
  double traj_steps = 0;
  for (auto _ : state) {
    const auto out = simulate_batch(cfgs);
    for (const auto& r : out) {
      if (r.status != RunStatus::kOk) {
        state.SkipWithError(r.reason.c_str());
        return;
      }
      traj_steps += static_cast<double>(r.steps);
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.SetLabel(to_string(model));
  state.counters["traj_steps_per_s"] = benchmark::Counter(traj_steps, benchmark::Counter::kIsRate);
}

void BM_Single(benchmark::State& state) {
  const auto model = static_cast<ModelKind>(state.range(0));
  const SimConfig cfg = lane_cfg(model, 0);
  double traj_steps = 0;
  for (auto _ : state) {
    const SimResult r = simulate(cfg);
    if (r.status != RunStatus::kOk) {
      state.SkipWithError(r.reason.c_str());
      return;
    }
    traj_steps += static_cast<double>(r.steps);
    benchmark::DoNotOptimize(r.x_end);
  }
  state.SetLabel(to_string(model));
  state.counters["traj_steps_per_s"] = benchmark::Counter(traj_steps, benchmark::Counter::kIsRate);
}

void Models(benchmark::internal::Benchmark* b) {
  for (int m = 0; m < 4; ++m) b->Arg(m);
}
void ModelsLanes(benchmark::internal::Benchmark* b) {
  for (int m = 0; m < 4; ++m)
    for (int lanes : {8, 64}) b->Args({m, lanes});
}

}  // namespace

BENCHMARK(BM_Batch)->Apply(ModelsLanes)->Unit(benchmark::kMillisecond)->MinTime(0.5);
BENCHMARK(BM_Single)->Apply(Models)->Unit(benchmark::kMillisecond)->MinTime(0.5);

BENCHMARK_MAIN();
