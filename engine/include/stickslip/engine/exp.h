#pragma once
// exp(x) written out by hand so that g++ can vectorise it.
//
// Why not std::exp: g++ 12 only vectorises std::exp through glibc's libmvec, and glibc declares
// the vector variants only under __FAST_MATH__ (-ffast-math), which this project does not use
// (divergence detection relies on NaN/Inf semantics). libmvec's results also differ from the
// scalar std::exp by up to 4 ulp, so a batched run would not reproduce a single run. This
// function is used by BOTH the scalar models and the batched kernels, so a lane of a batch is
// bitwise the same trajectory as simulate() of that lane's configuration.
//
// Method (Cody & Waite range reduction, as in fdlibm's e_exp.c):
//   n = round(x / ln 2)  (by the 1.5 * 2^52 shifter, which leaves n in the low mantissa bits)
//   r = x - n ln2_hi - n ln2_lo,  |r| <= ln(2)/2 (+ rounding)
//   exp(x) = 2^n (1 + r P(r)),  P(r) = sum_{i=0..12} r^i / (i+1)!  (Taylor, degree 13 overall:
//            truncation error |r|^14/14! < 4.2e-18 relative, far below one ulp = 2.2e-16).
//   P is evaluated by Estrin's scheme (depth 4 instead of Horner's 12 dependent steps, so the
//   latency is about that of glibc's exp) with explicit fmadd (std::fma), one instruction with
//   -mfma and, being explicit, the same operation in scalar and vectorised code.
//   2^n is assembled directly in the exponent bits.
// Domain: x in [-708, 709] (normal results). Beyond that the caller must not use the value
// (LuGre's Stribeck factor returns 0 for x < -708; see models.h). Accuracy: max relative error
// vs std::exp 2.2e-16 (1 ulp) measured; Batch.ExpMatchesStdExp asserts < 2.5e-16 over the domain.
#include <bit>
#include <cmath>
#include <cstdint>

namespace stickslip::engine {

/// a * b + c in one rounding where the target has FMA (one instruction), else two roundings.
/// Explicit, so that scalar and vectorised code do the same operation (the engine compiles the
/// rk4 and batched files with -ffp-contract=off, see engine/CMakeLists.txt) while the latency
/// chain of an RK4 step still gets fused multiply-adds.
inline double fmadd(double a, double b, double c) noexcept {
#if defined(__FMA__) || defined(__aarch64__)
  return std::fma(a, b, c);
#else
  return a * b + c;
#endif
}

/// 1 / k! for k = 0 ... 19 (every entry is the double nearest to 1/k!; the factorials up to 19!
/// are exact in double). The Taylor coefficients of exp_vectorizable and of the adaptive
/// integrator's small-angle sin/cos.
inline constexpr double kInvFactorial[20] = {
    1.0,                    1.0,
    1.0 / 2,                1.0 / 6,
    1.0 / 24,               1.0 / 120,
    1.0 / 720,              1.0 / 5040,
    1.0 / 40320,            1.0 / 362880,
    1.0 / 3628800,          1.0 / 39916800,
    1.0 / 479001600,        1.0 / 6227020800.0,
    1.0 / 87178291200.0,    1.0 / 1307674368000.0,
    1.0 / 20922789888000.0, 1.0 / 355687428096000.0,
    1.0 / 6402373705728000.0, 1.0 / 121645100408832000.0};

inline double exp_vectorizable(double x) noexcept {
  constexpr double kLog2e = 1.4426950408889634074;
  constexpr double kShift = 0x1.8p52;                    // 1.5 * 2^52
  constexpr double kLn2Hi = 6.93147180369123816490e-01;  // fdlibm ln2_hi (33 bits)
  constexpr double kLn2Lo = 1.90821492927058770002e-10;  // ln 2 - ln2_hi
  constexpr const double* c = kInvFactorial + 1;  // c[i] = 1 / (i+1)!, i = 0 ... 12
  const double kd = fmadd(x, kLog2e, kShift);
  const double n = kd - kShift;
  const double r = fmadd(-n, kLn2Lo, fmadd(-n, kLn2Hi, x));
  const double r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const double a0 = fmadd(c[1], r, c[0]), a1 = fmadd(c[3], r, c[2]);
  const double a2 = fmadd(c[5], r, c[4]), a3 = fmadd(c[7], r, c[6]);
  const double a4 = fmadd(c[9], r, c[8]), a5 = fmadd(c[11], r, c[10]);
  const double b0 = fmadd(a1, r2, a0), b1 = fmadd(a3, r2, a2), b2 = fmadd(a5, r2, a4);
  const double q0 = fmadd(b1, r4, b0), q1 = fmadd(c[12], r4, b2);
  const double P = fmadd(q1, r8, q0);
  const double p = fmadd(r, P, 1.0);
  // The low 12 bits of kd's pattern hold n (two's complement); n + 1023 is the biased exponent.
  const std::uint64_t bits = std::bit_cast<std::uint64_t>(kd);
  return p * std::bit_cast<double>((bits + 1023u) << 52);
}

}  // namespace stickslip::engine
