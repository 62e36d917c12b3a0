#pragma once
// Internal: the batched fixed-step RK4 kernel. One chunk of L lanes (trajectories) advances
// through all stages together; per step, the base phase is computed once (BasePhase) and the
// lane loop runs the same inline rk4_plain_step as the single-trajectory rk4, so g++ vectorises
// it across lanes when the model's batched form is branch-free (LuGre, Karnopp, Reset Integrator,
// Dahl with kappa = 1). Model parameters are stored one column per field (structure of arrays)
// and reassembled per lane with std::bit_cast, which the compiler turns into vector loads.
// Included by batch_kernels.cpp only (compiled with the vector flags). A model chooses its
// batched form with a static run_batch(kernel) (Dahl), else it runs as it is.
#include <array>
#include <bit>
#include <cfloat>
#include <cmath>
#include <type_traits>
#include <vector>

#include "batch_chunk.h"
#include "batch_metrics.h"
#include "rk4_step.h"
#include "stickslip/engine/batch.h"
#include "system.h"

namespace stickslip::engine::detail {

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

/// Runs one chunk of L lanes with the batched form B of model M: lane j runs conv(models[j])
/// (models: one per real lane, validated; padding lanes repeat lane 0).
template <class B, int L, class M, class Conv>
void run_chunk(const ChunkIO& io, const std::vector<M>& models, Conv&& conv) {
  static_assert(L <= kBatchMaxLanes);
  constexpr int Z = M::kStates;
  constexpr int ZS = Z > 1 ? Z - 1 : 0;  // internal states beyond s
  static_assert(B::kStates == Z);
  using State = StateT<Z>;
  const SimConfig& ref = *io.cfg[0];
  auto lane = [&](int j) { return j < io.lanes ? j : 0; };
  auto cfg_of = [&](int j) -> const SimConfig& { return *io.cfg[lane(j)]; };
  auto model_of = [&](int j) -> const M& { return models[static_cast<std::size_t>(lane(j))]; };

  ModelColumns<B, L> mc;
  alignas(64) double m_inv[L], k_d[L], v_d[L], v_lim[L], s_lim[L], thr[L];
  alignas(64) double x[L] = {}, v[L] = {}, s[L] = {}, fd[L], ff[L], bad[L], alive[L];
  alignas(64) std::array<std::array<double, L>, ZS> zs{}, zs_lim{};
  for (int j = 0; j < L; ++j) {
    const SimConfig& c = cfg_of(j);
    mc.set(j, conv(model_of(j)));
    m_inv[j] = make_plant(c).m_inv;
    k_d[j] = c.drive.k_d;
    v_d[j] = c.drive.v_d;
    const auto g = make_guard(c, model_of(j));
    v_lim[j] = g.v_limit;
    s_lim[j] = g.s_limit;
    for (int q = 0; q < ZS; ++q) zs_lim[q][j] = g.zs_limit[q];
    thr[j] = c.metrics.cycle_threshold;
    alive[j] = j < io.lanes ? 1.0 : 0.0;
  }
  auto lane_state = [&](int j) {
    State y{x[j], v[j], s[j]};
    if constexpr (Z > 1)
      for (int q = 0; q < ZS; ++q) y.zs[q] = zs[q][j];
    return y;
  };
  auto set_end = [&](int j) {
    SimResult& r = *io.out[j];
    r.x_end = x[j];
    r.v_end = v[j];
    r.s_end = primary_state(model_of(j), lane_state(j));
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
        const B model = mc.get(j);
        const Plant p{m_inv[j], k_d[j], v_d[j]};
        State y = lane_state(j);
        const auto k1 = rk4_plain_step(model, p, t, h, y, ub0, ubh, ubf);
        x[j] = y.x;
        v[j] = y.v;
        s[j] = y.s;
        fd[j] = k1.F_d;
        ff[j] = k1.F_f;
        // DivergenceGuard::ok, with isfinite(x) written as a comparison that vectorises.
        bool ok =
            std::fabs(y.v) < v_lim[j] && std::fabs(y.s) < s_lim[j] && std::fabs(y.x) <= DBL_MAX;
        if constexpr (Z > 1) {
          for (int q = 0; q < ZS; ++q) {
            zs[q][j] = y.zs[q];
            ok = ok && std::fabs(y.zs[q]) < zs_lim[q][j];
          }
        }
        bad[j] = ok ? 0.0 : alive[j];
      }
      acc.sample(t, fd, ff);
      bool any_bad = false;  // (a max-reduction inside the lane loop would block vectorising)
      for (int j = 0; j < L; ++j) any_bad = any_bad || bad[j] != 0.0;
      if (any_bad) {
        for (int j = 0; j < L; ++j) {
          if (bad[j] == 0.0) continue;
          SimResult& r = *io.out[j];
          const State y = lane_state(j);
          r.status = RunStatus::kDiverged;
          r.t_end = t + h;
          r.reason = divergence_reason(model_of(j), t + h, y.v, y.s, y.v - ubf, h);
          set_end(j);
          alive[j] = 0.0;
          x[j] = v[j] = s[j] = 0.0;  // keep the dead lane's arithmetic finite and cheap
          for (int q = 0; q < ZS; ++q) zs[q][j] = 0.0;
        }
        bool any_alive = false;
        for (int j = 0; j < L; ++j) any_alive = any_alive || alive[j] != 0.0;
        if (!any_alive) return;
      }
    }
    const double ub_end = base.base_velocity(t1);
    for (int j = 0; j < L; ++j) {
      const auto e = rhs(mc.get(j), Plant{m_inv[j], k_d[j], v_d[j]}, t1, lane_state(j), ub_end);
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

/// A chunk's validated per-lane models, offered to the model's run_batch hook.
template <class M>
class ChunkKernel {
 public:
  explicit ChunkKernel(const ChunkIO& io) : io_(io) {
    for (int j = 0; j < io.lanes; ++j) models_.push_back(make_model<M>(*io.cfg[j]));
  }
  /// True when pred(model) holds on every real lane.
  template <class Pred>
  bool all(Pred&& pred) const {
    for (const M& m : models_)
      if (!pred(m)) return false;
    return true;
  }
  /// Runs the chunk with the batched form B, lane j's B being conv(lane j's model).
  template <class B, class Conv>
  void run(Conv&& conv) const {
    run_chunk<B, kBatchLanes>(io_, models_, conv);
  }

 private:
  const ChunkIO& io_;
  std::vector<M> models_;
};

template <class M>
void run_chunk_of(const ChunkIO& io) {
  const ChunkKernel<M> kernel(io);
  if constexpr (requires { M::run_batch(kernel); }) M::run_batch(kernel);
  else kernel.template run<M>([](const M& m) { return m; });
}

}  // namespace stickslip::engine::detail
