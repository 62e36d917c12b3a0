#pragma once
// The hidden-effect suite of issue 5, shared by the tests (tests/diagnosis/test_diagnose.cpp) and
// the confusion-table program (bench/diagnose_suite.cpp): synthetic LuGre datasets with one
// catalogue effect hidden at a stated size (or none), and what the diagnosis must say.
//
// Dataset design (docs/diagnose.md "Hidden-effect suite"): every run starts with a still base
// (stick-slip, t < t_on) and then vibrates at one v_a in {1.5, 3, 5} mm/s (f = 1500 Hz), so the
// stage-2 level is seen against v_a. These conditions are not chaotic for LuGre (the chaotic
// seed condition is v_a = 0.2 mm/s; see docs/diagnose.md). Base parameters are 5-10 % off
// Table 1 (F_S x 1.06, F_C x 0.95, v_s x 0.92), the noise is white or AR(1), 0.02-0.05 N,
// with a 0.1 N sensor offset.

#include <cstdint>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/measured/synth.h"

namespace stickslip::diagnosis {

struct HiddenCase {
  std::string name;                          ///< e.g. "viscous", "clean_ar1", "small_drift"
  engine::ExtensionKind kind = engine::ExtensionKind::kNone; ///< hidden effect (none for the null)
  std::string param;                         ///< its size parameter (empty for the null)
  double value = 0;                          ///< hidden size (SI)
  double rel_tol = 0.3;                      ///< recovery tolerance of the size, relative [-]
  bool small = false;   ///< too small to see: "none" or the right cause, never a wrong one
  double noise = 0.03;  ///< [N]
  double noise_rho = 0; ///< AR(1) coefficient [-]
  /// Runs in default CI, on one seed, against ci_candidates only (an effect: its own candidate;
  /// a null: viscous and waviness); every case runs against the whole catalogue on two seeds
  /// with STICKSLIP_DIAG_LONG=1 (or STICKSLIP_DIAGNOSE_SUITE; docs/diagnose.md "Tests").
  bool in_ci = false;
  std::vector<engine::ExtensionKind> ci_candidates = {};
  /// Further parameters of the hidden effect (engine names, SI), e.g. {"load_phi", 1.0}.
  std::vector<std::pair<std::string, double>> more = {};
  /// The candidate's reported parameter that is judged, against judged_value within rel_tol;
  /// empty: its first reported parameter against value. (normal_load_modulation: only the
  /// in-phase component load_eta_v = eta sin(phi) is well identified, diagnose_load.h.)
  std::string judged = {};
  double judged_value = 0;
  /// Run conditions of this case's own (empty / 0: the shared ones below). For effects the
  /// shared conditions cannot identify (docs/diagnose.md "branch diag-shape"): v_a per run
  /// [m/s], start of the vibration t_on [s] and run length [s] (CI and full datasets).
  std::vector<double> own_va = {};
  double own_t_on = 0;
  double own_duration = 0;
};

/// GoogleTest prints a case by its name (not as bytes) in test names and messages.
inline void PrintTo(const HiddenCase& c, std::ostream* os) { *os << c.name; }

/// Every catalogue effect at a moderate size, the nulls (white and AR(1) noise) and a few
/// effects too small to see.
std::vector<HiddenCase> hidden_effect_cases();
/// The case of hidden_effect_cases() with this name; std::invalid_argument naming it otherwise.
HiddenCase hidden_case(std::string_view name);

/// The suite's dataset families.
enum class SuiteDatasets {
  kCi,    ///< 2 runs x 4.5 s, t_on = 3 s, v_a = 1.5 and 5 mm/s, 1 kHz (default CI)
  kFull,  ///< 3 runs x 7 s, t_on = 4 s, v_a = 1.5, 3 and 5 mm/s, 2 kHz
  /// The seed's conditions for every case (own conditions ignored): 3 runs x 20 s, t_on = 10 s,
  /// v_a = 0, 1.1 and 4 mm/s, 2 kHz, as the speed benchmark (bench/bench_diagnose.cpp).
  kSeed,
};

/// The synthetic dataset of a case for a seed.
measured::SynthOptions hidden_case_dataset(const HiddenCase& c, std::uint64_t seed, SuiteDatasets family);

/// Diagnosis options used by the suite: every base model for kFull, the LuGre base only for the
/// others (CI time; kSeed: an hour for the suite otherwise).
DiagnoseOptions hidden_case_options(SuiteDatasets family);

/// What the diagnosis said against what it had to say.
struct HiddenVerdict {
  bool cause_ok = false, gain_ok = false, param_ok = false;
  double recovered = 0;  ///< fitted size parameter of the hidden effect's candidate (SI)
  double truth = 0;      ///< what recovered is compared with (value or judged_value)
  bool ok() const { return cause_ok && gain_ok && param_ok; }
};
HiddenVerdict judge(const HiddenCase& c, const Diagnosis& d);

// ---- the randomised suite (issue 21 item 8) --------------------------------------------------
//
// Every case draws, from its seed, every parameter a user's rig could vary (random_suite_ranges
// states the ranges): all of LuGre's parameters (F_S, F_C, v_s, k_t, h_t; h_v = 0, which the
// catalogue's viscous term stands for) a few per cent off Table 1, the hidden effect's size and
// its other parameters, the noise level and its AR(1) coefficient, the sensor offset and, for
// the short family, the run lengths, the switch times and the v_a set. The seed family keeps
// the seed's conditions: 3 runs x 20 s, v_a = 0, 1.1 and 4 mm/s from t_on = 10 s, 2 kHz.

enum class RandomFamily {
  kSeed,   ///< the seed's conditions (above)
  kShort,  ///< 2 or 3 runs of 6-9 s, t_on at 45-60 %, v_a drawn in 1.2-5 mm/s, 1 or 2 kHz
};

struct RandomCase {
  std::string name;  ///< "<effect or null_white / null_ar1>#<seed>"
  engine::ExtensionKind kind = engine::ExtensionKind::kNone;
  std::uint64_t seed = 0;
  measured::SynthOptions data;  ///< the truth and the conditions
  std::string judged;           ///< the candidate's reported parameter judged (empty: none)
  double truth = 0;             ///< its true value
  double rel_tol = 0.3;         ///< recovery tolerance [-]
  /// Every drawn number by name (the base's parameters, the effect's, noise, rho, offset).
  std::vector<std::pair<std::string, double>> drawn;
};

/// The cases of one seed: every catalogue effect once and two nulls (white and AR(1) noise).
std::vector<RandomCase> random_cases(std::uint64_t seed, RandomFamily family);
/// The ranges the cases are drawn from, as text (one line per quantity).
std::string random_suite_ranges();
/// What the diagnosis said against the case: the cause (nulls: none), a positive held-out gain
/// and the judged parameter within rel_tol.
HiddenVerdict judge(const RandomCase& c, const Diagnosis& d);

}  // namespace stickslip::diagnosis
