#pragma once
// Internal: the batched fixed-step RK4 kernel. One chunk of L lanes (trajectories) advances
// through all stages together; per step, the base phase is computed once (BasePhase) and the
// lane loop runs the same inline rk4_plain_step as the single-trajectory rk4, so g++ vectorises
// it across lanes when the model is branch-free (LuGre, Karnopp, Reset Integrator, Dahl with
// kappa = 1). Model parameters are stored one column per field (structure of arrays) and
// reassembled per lane with std::bit_cast, which the compiler turns into vector loads.
#include <array>
#include <bit>
#include <cfloat>
#include <cmath>
#include <type_traits>

#include "batch_metrics.h"
#include "rk4_step.h"
#include "stickslip/engine/batch.h"
#include "system.h"

namespace stickslip::engine::detail {

/// One chunk: lanes [0, lanes) are real; the kernel pads the rest with copies of lane 0.
struct ChunkIO {
  std::array<const SimConfig*, kBatchMaxLanes> cfg{};
  std::array<SimResult*, kBatchMaxLanes> out{};
  int lanes = 0;
};

/// Lanes per chunk for each model's kernel (the kernels below are instantiated with these).
inline constexpr int kLanesLuGre = 16, kLanesKarnopp = 16, kLanesDahl = 16, kLanesReset = 16;

void run_chunk_lugre(const ChunkIO& io);
void run_chunk_karnopp(const ChunkIO& io);
void run_chunk_dahl(const ChunkIO& io);
void run_chunk_reset(const ChunkIO& io);

/// A model's fields as L-wide columns. Models are structs of doubles (checked below).
template <class Model, int L>
struct ModelColumns {
  static constexpr int N = static_cast<int>(sizeof(Model) / sizeof(double));
  static_assert(sizeof(Model) == N * sizeof(double) && std::is_trivially_copyable_v<Model>,
                "batched models must be trivially copyable structs of doubles");
  using Row = std::array<double, N>;
  alignas(64) double col[N][L];
  void set(int j, const Model& m) noexcept {
    const Row r = std::bit_cast<Row>(m);
    for (int k = 0; k < N; ++k) col[k][j] = r[k];
  }
  Model get(int j) const noexcept {
    Row r;
    for (int k = 0; k < N; ++k) r[k] = col[k][j];
    return std::bit_cast<Model>(r);
  }
};

/// Runs one chunk of L lanes with model type Model built per lane by make(cfg).
template <class Model, int L, class Make>
void run_chunk(const ChunkIO& io, Make&& make) {
  static_assert(L <= kBatchMaxLanes);
  const SimConfig& ref = *io.cfg[0];
  auto cfg_of = [&](int j) -> const SimConfig& { return *io.cfg[j < io.lanes ? j : 0]; };

  ModelColumns<Model, L> mc;
  alignas(64) double m_inv[L], k_d[L], v_d[L], v_lim[L], s_lim[L], thr[L];
  alignas(64) double x[L] = {}, v[L] = {}, s[L] = {}, fd[L], ff[L], bad[L], alive[L];
  for (int j = 0; j < L; ++j) {
    const SimConfig& c = cfg_of(j);
    mc.set(j, make(c));
    m_inv[j] = make_plant(c).m_inv;
    k_d[j] = c.drive.k_d;
    v_d[j] = c.drive.v_d;
    const DivergenceGuard g = make_guard(c);
    v_lim[j] = g.v_limit;
    s_lim[j] = g.s_limit;
    thr[j] = c.metrics.cycle_threshold;
    alive[j] = j < io.lanes ? 1.0 : 0.0;
  }
  auto lane_state = [&](int j) { return State{x[j], v[j], s[j]}; };
  auto set_end = [&](int j) {
    SimResult& r = *io.out[j];
    r.x_end = x[j];
    r.v_end = v[j];
    r.s_end = s[j];
  };

  double t0 = 0.0;
  for (const Stage& st : ref.stages) {
    const double t1 = t0 + st.duration;
    Plant base = make_plant(ref);
    base.v_a = st.v_a;
    base.w = 2.0 * M_PI * st.f;
    base.t0 = t0;
    const long n = steps_for(t1 - t0, ref.integrator.dt);
    const double h = (t1 - t0) / static_cast<double>(n);
    BasePhase ph(base.w, h);
    LaneAccumulators<L> acc(t0, t1, ref.metrics.settle_fraction, thr);
    for (long k = 0; k < n; ++k) {
      const double t = t0 + static_cast<double>(k) * h;
      ph.advance(k, t - t0);
      const double ub0 = st.v_a * ph.c0(), ubh = st.v_a * ph.c_half();
      const double ubf = st.v_a * ph.c_full();
      for (int j = 0; j < L; ++j) {  // the vectorised lane loop
        const Model model = mc.get(j);
        const Plant p{m_inv[j], k_d[j], v_d[j]};
        State y{x[j], v[j], s[j]};
        const Deriv k1 = rk4_plain_step(model, p, t, h, y, ub0, ubh, ubf);
        x[j] = y.x;
        v[j] = y.v;
        s[j] = y.s;
        fd[j] = k1.F_d;
        ff[j] = k1.F_f;
        // DivergenceGuard::ok, with isfinite(x) written as a comparison that vectorises.
        const bool ok =
            std::fabs(y.v) < v_lim[j] && std::fabs(y.s) < s_lim[j] && std::fabs(y.x) <= DBL_MAX;
        bad[j] = ok ? 0.0 : alive[j];
      }
      acc.sample(t, fd, ff);
      bool any_bad = false;  // (a max-reduction inside the lane loop would block vectorising)
      for (int j = 0; j < L; ++j) any_bad = any_bad || bad[j] != 0.0;
      if (any_bad) {
        for (int j = 0; j < L; ++j) {
          if (bad[j] == 0.0) continue;
          SimResult& r = *io.out[j];
          r.status = RunStatus::kDiverged;
          r.t_end = t + h;
          r.reason = divergence_reason(cfg_of(j), t + h, lane_state(j), ubf, h);
          set_end(j);
          alive[j] = 0.0;
          x[j] = v[j] = s[j] = 0.0;  // keep the dead lane's arithmetic finite and cheap
        }
        bool any_alive = false;
        for (int j = 0; j < L; ++j) any_alive = any_alive || alive[j] != 0.0;
        if (!any_alive) return;
      }
    }
    const double ub_end = base.base_velocity(t1);
    for (int j = 0; j < L; ++j) {
      const Deriv e = rhs(mc.get(j), Plant{m_inv[j], k_d[j], v_d[j]}, t1, lane_state(j), ub_end);
      fd[j] = e.F_d;
      ff[j] = e.F_f;
    }
    acc.sample(t1, fd, ff);
    for (int j = 0; j < io.lanes; ++j) {
      if (alive[j] == 0.0) continue;
      SimResult& r = *io.out[j];
      r.steps += static_cast<std::size_t>(n);
      r.stages.push_back(acc.finish(j));
      set_end(j);
    }
    t0 = t1;
  }
  for (int j = 0; j < io.lanes; ++j)
    if (alive[j] != 0.0) io.out[j]->t_end = t0;
}

}  // namespace stickslip::engine::detail
