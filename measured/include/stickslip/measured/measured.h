#pragma once
// Measured drive-force data (schemas/measured.schema.json): a JSON manifest naming CSV files.
//
//   {"name": "stand-2026-11-20",
//    "runs": [{"name": "va0.2", "file": "va0.2.csv",
//              "conditions": {"m": 0.665, "kd": 11700, "vd": 0.001, "f": 1500, "va": 0.0002,
//                             "t_on": 10, "duration": 20}}]}
//
// file is relative to the manifest's directory. Conditions are SI; a missing condition takes
// the seed's value (m 0.665 kg, kd 11700 N/m, vd 1e-3 m/s, f 1500 Hz, va 0, t_on 10 s,
// duration 20 s). The base is still before t_on and vibrates from t_on on.
// A CSV has a header row with at least the columns t [s] and Fd [N]; other columns are
// ignored; sampling may be uneven but t must increase strictly.

#include <cstddef>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/engine/params.h"
#include "stickslip/common/json_schema.h"

namespace stickslip::measured {

/// The conditions of one measured run (SI).
struct MeasuredConditions {
  double m = 0.665;      ///< [kg]
  double kd = 11700.0;   ///< [N/m]
  double vd = 1e-3;      ///< [m/s]
  double Fz = 29.4;      ///< external normal load [N]; F_N = Fz + m g (0: the weight alone)
  double f = 1500.0;     ///< [Hz]
  double va = 0.0;       ///< [m/s]
  double t_on = 10.0;    ///< [s] vibration starts
  double duration = 20.0;  ///< [s] whole run
  /// The manifest keys of the conditions it left out, whose seed values above were taken
  /// ("Fz", "f" ...); empty for a synthesised run or when every condition is given.
  std::vector<std::string> defaulted;
};

/// "Fz = 29.4 N, f = 1500 Hz": the defaulted conditions with their values and units.
std::string defaulted_text(const MeasuredConditions& c);

struct MeasuredRun {
  std::string name;
  std::string file;  ///< as written in the manifest
  MeasuredConditions conditions;
  std::vector<double> t;   ///< [s], strictly increasing
  std::vector<double> Fd;  ///< [N]
};

struct MeasuredDataset {
  std::string name;
  std::filesystem::path manifest;  ///< absolute path of the manifest
  std::vector<MeasuredRun> runs;
};

/// Every problem found while loading: schema errors carry JSON pointers (like studies); CSV
/// errors name the file and the 1-based line.
class MeasuredError : public std::runtime_error {
 public:
  explicit MeasuredError(std::vector<common::SpecError> errors);
  const std::vector<common::SpecError>& errors() const noexcept { return errors_; }

 private:
  std::vector<common::SpecError> errors_;
};

/// Smallest number of samples a measured run may have.
inline constexpr std::size_t kMinMeasuredSamples = 20;

/// Loads and checks a manifest and all its CSV files. Throws MeasuredError listing every problem.
MeasuredDataset load_measured(const std::filesystem::path& manifest);

/// The same checks on a dataset held in memory (the server's POST /v1/diagnoses): manifest is
/// the parsed manifest, files maps each run's `file` (a plain name, no directory part) to the
/// CSV text. Nothing is read from disk. Error pointers are into the document
/// {"manifest": manifest, "files": files}: schema errors under /manifest, a path-like or missing
/// file at /manifest/runs/<i>/file, CSV problems at /files/<name> with a message
/// "<name>:<line>: <problem>", a path-like name or a file no run names at /files/<name>.
/// The dataset's manifest path is empty. Throws MeasuredError listing every problem.
MeasuredDataset load_measured(const nlohmann::json& manifest,
                              const std::map<std::string, std::string>& files);

/// Applies a run's conditions to cfg: drive m, k_d, v_d, and the stages [0, t_on) still and
/// [t_on, duration) at va, f (only the second when t_on = 0, only the first when
/// t_on = duration). Other fields of cfg are kept.
void apply_conditions(const MeasuredConditions& c, engine::SimConfig& cfg);

/// True when cfg has these conditions: the same m, k_d, v_d and the same base motion over time
/// (when it starts and stops vibrating, at which v_a and f; the frequency of a still base and
/// how the time is cut into stages do not matter). Relative tolerance 1e-9 on every number.
bool matches_conditions(const engine::SimConfig& cfg, const MeasuredConditions& c);

/// Root-mean-square error (eq. 23 of the seed) between measured samples (t, Fd) and a simulated
/// F_d(t) given as samples (ts, Fs) (linearly interpolated), over measured samples with
/// t0 <= t < t1. NaN when no measured sample falls in the window.
double rmse_window(const std::vector<double>& t, const std::vector<double>& Fd,
                   const std::vector<double>& ts, const std::vector<double>& Fs, double t0,
                   double t1);

}  // namespace stickslip::measured
