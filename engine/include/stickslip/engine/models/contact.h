#pragma once
// Parameters that several friction models share: the same name always means the same physical
// quantity, with one unit, default and allowed range (the registry checks that every model's
// row of a shared name agrees). Each model's header adds its own fit range (ParamDef::with_fit).
// Defaults: the seed's Table 1 (Rybkiewicz & Leus).
#include "stickslip/engine/model_api.h"

namespace stickslip::engine::contact {

inline constexpr ParamDef kKt{"k_t", kStiffness, 71.318e6, kPositive,
                                     "tangential contact stiffness"};
inline constexpr ParamDef kFC{"F_C", kForce, 8.3, kPositive,
                                        "Coulomb (sliding) friction force (Karnopp's F_slip)",
                                        {}, "F_slip"};
inline constexpr ParamDef kFS{"F_S", kForce, 11.1, kPositive,
                                       "static friction force"};
/// The Stribeck curve's velocity and the bristle's damping of LuGre (the seed's eqs. 18-22),
/// shared by the models built on its bristle or its Stribeck curve (elasto-plastic, GMS).
inline constexpr ParamDef kVs{"v_s", kVelocity, 3.5e-4, kPositive, "Stribeck velocity"};
inline constexpr ParamDef kHt{"h_t", kDamping, 1.377e4, kNonNegative,
                              "bristle (presliding) damping (the seed's eq. 21 with zeta = 1)"};
inline constexpr ParamDef kHv{"h_v", kDamping, 0.0, kNonNegative, "viscous damping"};

/// Start a force-level parameter from the measured breakaway / sliding level.
inline constexpr FitStart kStartStick = [](const FitLevels& l) { return l.stick; };
inline constexpr FitStart kStartSlip = [](const FitLevels& l) { return l.slip; };
/// The Stribeck-model pair: F_S from the breakaway level in [0.5, 60] N (log), F_C as the
/// fraction F_C/F_S in [0.3, 1] (which keeps F_C <= F_S), started from the measured ratio.
inline constexpr FitRange kFitStaticForce{0.5, 60.0, FitScale::kLog, kStartStick};
inline constexpr FitRange kFitCoulombFraction{
    0.3, 1.0, FitScale::kLinear,
    [](const FitLevels& l) { return std::clamp(l.slip / l.stick, 0.31, 0.999); }, "F_S"};

}  // namespace stickslip::engine::contact
