#pragma once
// THROWAWAY (issue 19 demonstration, reverted): a regularised Coulomb law with no internal state.
//   F_f = F_C tanh(v_r / v_e)                                                          [N]
#include <cmath>

#include "stickslip/engine/model_api.h"
#include "stickslip/engine/models/contact.h"

namespace stickslip::engine {

struct TanhCoulomb {
  static constexpr ModelInfo kInfo{"tanh_coulomb", "Tanh Coulomb", "a throwaway test model",
                                   ModelClass::kSmooth, StateInfo{"s", kLength, "unused (always 0)"},
                                   "a throwaway model: no batched kernel", kAllIntegrators,
                                   false};
  static constexpr ParamDef kParams[] = {
      contact::kFC.with_fit({0.3, 60.0, FitScale::kLog, contact::kStartSlip}),
      {"v_e", kVelocity, 1e-3, kPositive, "tanh regularisation velocity",
       {1e-6, 1e-2, FitScale::kLog}},
  };
  static constexpr int kStates = 0;

  double F_C, v_e;

  explicit TanhCoulomb(const ModelInputs& in) : F_C(in["F_C"]), v_e(in["v_e"]) {}

  FrictionEval operator()(double v_r, double /*s*/, double /*F_d*/) const noexcept {
    return {F_C * std::tanh(v_r / v_e), 0.0};
  }
  ErrorWeights<0> error_weights(const Drive& d) const noexcept {
    return {std::sqrt(d.k_d * d.m), {}};
  }
  std::array<double, 0> state_scale(double /*f_ref*/) const noexcept { return {}; }
};

}  // namespace stickslip::engine
