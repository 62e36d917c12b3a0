#pragma once
// Internal to the diagnosis: scale-free parameter ranges and starts (docs/diagnose.md
// "Calibration"). The registry's fit ranges (ParamDef::fit, base_specs) are written around the
// seed's Table 1: forces of ~10 N, k_d = 11700 N/m, v_d = 1 mm/s. A record of another rig is
// fitted in the same box moved to its own scales, by each parameter's physical dimension
// (ParamDef::dim, force^a length^b time^c):
//   force  F* = the record's sliding level (mean of every run's first fitted window) against
//               Table 1's F_C;
//   length F*/k_d against F_C/k_d of Table 1;
//   time   (F*/k_d)/v_d, the time the drive takes to load the spring by F*;
//   a coefficient of the normal load (FitRange::per_normal_load, rate-and-state's mu0, a, b)
//          F*/F_N, F_N = Fz + m g from each run's conditions, against F_C/F_N of Table 1
//          (8.3 N / 35.9 N). So a 0.1 N record at F_N = 0.30 N starts at mu0 = 0.33, and the
//          same record with Table 1's external load (a manifest without "Fz") at 0.0034.
// With runs at several k_d and v_d, a range spans them all (the lower end scaled by the smallest
// factor over the runs, the upper by the largest) and a start is scaled at their geometric means.
//
// Every other parameter of the model with a positive default (LuGre's k_t and h_t, the Reset
// Integrator's k_t and beta, Karnopp's DV) is a secondary parameter: its start is its Table 1
// default moved to the record's scales, its range a decade either way. The calibration frees it
// only when the data can identify it (identify_secondary): otherwise it is held there and
// reported as not identifiable.

#include <string>
#include <vector>

#include "stickslip/diagnosis/detail/diagnose_fit.h"

namespace stickslip::diagnosis::detail {

/// The scale factors of the record against Table 1.
struct RecordScales {
  double force = 1;                         ///< F* / F_C(Table 1) [-]
  std::vector<double> kd, vd;               ///< per run [N/m], [m/s]
  std::vector<double> normal_load;          ///< per run F_N = Fz + m g [N]
  /// The factor of dimension d for drive (kd, vd), and its smallest / largest / central value
  /// over the runs.
  double factor(const engine::Dim& d, double kd, double vd) const;
  double lo(const engine::Dim& d) const;
  double hi(const engine::Dim& d) const;
  double mid(const engine::Dim& d) const;
  /// The same for a coefficient of the normal load: (F*/F_N) / (F_C/F_N of Table 1).
  double coefficient(std::size_t run) const;
  double coefficient_lo() const;
  double coefficient_hi() const;
  double coefficient_mid() const;
};

RecordScales record_scales(const Problem& p);

/// The dimension of a fitted name (a parameter, or a ratio "a/b" of two of one dimension).
engine::Dim spec_dimension(engine::ModelKind m, const std::string& name);

/// base_specs moved to the record's scales (see above), started from the measured levels.
std::vector<ParamSpec> scaled_base_specs(engine::ModelKind m, const RecordScales& s,
                                         const StartLevels& levels);

/// The model's secondary parameters (see above) as specs at the record's scales.
std::vector<ParamSpec> secondary_specs(engine::ModelKind m, const RecordScales& s);

/// The dimension of a catalogue extension parameter (extensions.h declares none; written here).
engine::Dim extension_dimension(const std::string& name);

/// extension_specs(k) moved to the record's scales (ranges and starts).
std::vector<ParamSpec> scaled_extension_specs(engine::ExtensionKind k, const RecordScales& s);

/// A value of extension parameter `name` written at Table 1's scale, moved to the record's
/// (the central factor).
double scaled_extension_value(const std::string& name, double v, const RecordScales& s);

/// The model's parameter defaults moved to the record's scales, set in cfg (the values a fit
/// holds every parameter it does not free at).
void scale_defaults(engine::ModelKind m, const RecordScales& s, engine::SimConfig* cfg);

}  // namespace stickslip::diagnosis::detail
