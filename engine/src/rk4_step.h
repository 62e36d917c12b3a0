#pragma once
// Internal: one classic RK4 step of the seed's system with the base velocity given at the step
// start, middle and end. Shared by the single-trajectory rk4 (rk4.cpp) and the batched kernels
// (batch_kernel.h) so that a lane of a batch computes bitwise the same trajectory as simulate().
// Everything is inline and branch-free for branch-free models, so g++ vectorises it across lanes.
#include <algorithm>
#include <cmath>

#include "system.h"

namespace stickslip::engine::detail {

template <int Z, bool M>
inline StateStorage<Z, M> axpy(const StateStorage<Z, M>& y, double h,
                               const StateStorage<Z, M>& d) noexcept {
  StateStorage<Z, M> out{fmadd(h, d.x, y.x), fmadd(h, d.v, y.v), fmadd(h, d.s, y.s)};
  if constexpr (Z > 1)
    for (int k = 0; k < Z - 1; ++k) out.zs[k] = fmadd(h, d.zs[k], y.zs[k]);
  return out;
}

/// Advances y by one RK4 step of length h from time t. ub0, ub_half, ub_full: base velocity at
/// t, t + h/2, t + h [m/s]. Returns the first stage (forces at the step start, for metrics).
template <class Model>
inline DerivT<Model::kStates> rk4_plain_step(const Model& model, const Plant& p, double t, double h,
                                            StateOf<Model>& y, double ub0, double ub_half,
                                            double ub_full) noexcept {
  const auto k1 = rhs(model, p, t, y, ub0);
  const auto k2 = rhs(model, p, t + 0.5 * h, axpy(y, 0.5 * h, k1.d), ub_half);
  const auto k3 = rhs(model, p, t + 0.5 * h, axpy(y, 0.5 * h, k2.d), ub_half);
  const auto k4 = rhs(model, p, t + h, axpy(y, h, k3.d), ub_full);
  const double h6 = h / 6.0;
  y.x = fmadd(h6, k1.d.x + 2.0 * (k2.d.x + k3.d.x) + k4.d.x, y.x);
  y.v = fmadd(h6, k1.d.v + 2.0 * (k2.d.v + k3.d.v) + k4.d.v, y.v);
  y.s = fmadd(h6, k1.d.s + 2.0 * (k2.d.s + k3.d.s) + k4.d.s, y.s);
  if constexpr (Model::kStates > 1)
    for (int k = 0; k < Model::kStates - 1; ++k)
      y.zs[k] = fmadd(h6, k1.d.zs[k] + 2.0 * (k2.d.zs[k] + k3.d.zs[k]) + k4.d.zs[k], y.zs[k]);
  return k1;
}

/// Number of uniform steps covering a span with steps no longer than dt.
inline long steps_for(double span, double dt) {
  return std::max(1L, static_cast<long>(std::ceil(span / dt * (1.0 - 1e-12))));
}

/// Base-velocity phase by a rotation recurrence: one sin/cos pair per 1024 steps instead of three
/// cosines per step. Gives cos(w (t - t0)) at the step start, middle and end.
class BasePhase {
 public:
  BasePhase(double w, double h) : w_(w), ch_(std::cos(0.5 * w * h)), sh_(std::sin(0.5 * w * h)) {}
  /// Call once per step k (in order) with tau = t - t0 of the step start.
  void advance(long k, double tau) noexcept {
    if (k > 0) {
      c_ = c_full_;
      s_ = s_full_;
    }
    if ((k & 1023) == 0) {  // re-synchronise with the exact phase to stop drift
      c_ = std::cos(w_ * tau);
      s_ = std::sin(w_ * tau);
    }
    c_half_ = c_ * ch_ - s_ * sh_;
    s_half_ = s_ * ch_ + c_ * sh_;
    c_full_ = c_half_ * ch_ - s_half_ * sh_;
    s_full_ = s_half_ * ch_ + c_half_ * sh_;
  }
  double c0() const noexcept { return c_; }
  double c_half() const noexcept { return c_half_; }
  double c_full() const noexcept { return c_full_; }

 private:
  double w_, ch_, sh_;
  double c_ = 1.0, s_ = 0.0, c_half_ = 1.0, s_half_ = 0.0, c_full_ = 1.0, s_full_ = 0.0;
};

}  // namespace stickslip::engine::detail
