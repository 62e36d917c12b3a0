// Batched RK4 for Dahl and the Reset Integrator.
#include "batch_kernel.h"

namespace stickslip::engine::detail {
namespace {

/// Dahl restricted to kappa = 1: the same arithmetic as Dahl::operator()'s kappa == 1 branch,
/// without the std::pow branch that stops vectorisation.
struct DahlLinear {
  Dahl d;
  static constexpr bool kHasStrain = true;
  FrictionEval operator()(double v_r, double s, double /*F_d*/) const noexcept {
    const double one_minus = 1.0 - d.k_over_FC * sgn(v_r) * s;
    return {d.k_t * s, v_r * one_minus};
  }
};
// rhs() names eval_ext for extensions; batches never carry one (batch_compatible rejects them),
// but the template must still compile: forward to Dahl's.
inline FrictionEval eval_ext(const DahlLinear& m, const ExtRuntime& r, const Mod& mod, double v_r,
                             double s, double F_d) noexcept {
  return eval_ext(m.d, r, mod, v_r, s, F_d);
}

}  // namespace

void run_chunk_dahl(const ChunkIO& io) {
  bool linear = true;
  for (int j = 0; j < io.lanes; ++j) linear = linear && io.cfg[j]->friction.kappa == 1.0;
  if (linear)
    run_chunk<DahlLinear, kLanesDahl>(io, [](const SimConfig& c) { return DahlLinear{Dahl(c.friction)}; });
  else  // general kappa: std::pow per lane, correct but not vectorised
    run_chunk<Dahl, kLanesDahl>(io, [](const SimConfig& c) { return Dahl(c.friction); });
}

void run_chunk_reset(const ChunkIO& io) {
  run_chunk<ResetIntegrator, kLanesReset>(io,
                             [](const SimConfig& c) { return ResetIntegrator(c.friction); });
}

}  // namespace stickslip::engine::detail
