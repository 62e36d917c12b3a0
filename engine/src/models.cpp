#include "stickslip/engine/models.h"

#include <cmath>

namespace stickslip::engine {
namespace {
void positive(const char* name, double v) {
  if (!std::isfinite(v) || !(v > 0)) throw InvalidParameter(name, v, "must be a finite number > 0");
}
void non_negative(const char* name, double v) {
  if (!std::isfinite(v) || !(v >= 0))
    throw InvalidParameter(name, v, "must be a finite number >= 0");
}
}  // namespace

Dahl::Dahl(const FrictionParams& p) : k_t(p.k_t), kappa(p.kappa), F_C(p.F_C) {
  positive("k_t", k_t);
  positive("kappa", kappa);
  positive("F_C", F_C);
  k_over_FC = k_t / F_C;
}

Karnopp::Karnopp(const FrictionParams& p) : DV(p.DV), F_S(p.F_S), F_slip(p.F_C) {
  positive("DV", DV);
  positive("F_S", F_S);
  positive("F_slip", F_slip);
  if (F_S < F_slip) throw InvalidParameter("F_S", F_S, "must be >= F_slip (F_C)");
}

ResetIntegrator::ResetIntegrator(const FrictionParams& p)
    : k_t(p.k_t), beta(p.beta), s0(p.s0), alpha(p.alpha) {
  positive("k_t", k_t);
  non_negative("beta", beta);
  positive("s0", s0);
  non_negative("alpha", alpha);
}

LuGre::LuGre(const FrictionParams& p)
    : k_t(p.k_t), h_t(p.h_t), h_v(p.h_v), F_C(p.F_C), F_S(p.F_S), v_s(p.v_s) {
  positive("k_t", k_t);
  non_negative("h_t", h_t);
  non_negative("h_v", h_v);
  positive("F_C", F_C);
  positive("F_S", F_S);
  positive("v_s", v_s);
  if (F_S < F_C) throw InvalidParameter("F_S", F_S, "must be >= F_C");
  inv_vs2 = 1.0 / (v_s * v_s);
}

}  // namespace stickslip::engine
