#pragma once
// Study specification: parse and validate a study JSON document (schemas/study.schema.json, which
// is embedded in the library), then enumerate its runs on demand.
//
// A study is a base configuration, the stages of every run, integrator settings, a design (grid,
// list, random, lhs, sobol, morris) and output options; see the schema's descriptions for every
// field. parse_study() reports EVERY problem it finds, each with a JSON Pointer:
//   1. malformed JSON (pointer "", message with line and column) or duplicate keys;
//   2. schema violations (unknown fields by name, wrong types, bounds, sizes, enums);
//   3. checks the schema cannot express: parameter names known to the engine, parameter domains
//      (set_parameter), SimConfig::IsValid of the base, run count, duration and step limits,
//      duplicate or conflicting design names, linspace/logspace counts, ranges with min > max.
// A spec with any error yields no StudySpec.
//
// Design points. DesignPoint::values holds the design variables in the design's order:
//   grid   : one value per axis, in axis order (the "model" axis goes to DesignPoint::model);
//   list   : the point's keys in sorted (canonical JSON) order, "model" excluded;
//   random, lhs, sobol, morris : one value per range, in range order.
// "F_slip" is stored under its canonical name "F_C". When "va_over_vd" is present, the resolved
// "v_a" = va_over_vd * v_d is appended last, v_d being the point's own v_d if it sets one and the
// base v_d otherwise, so the result does not depend on the order of the axes.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/engine/params.h"
#include "stickslip/common/json_schema.h"

namespace stickslip::studies {

/// Server-side limits checked at parse time (and again by config_for for each point).
struct Limits {
  std::size_t max_runs = 100000;  ///< largest number of runs of one study [-]
  double max_duration = 3600;     ///< longest simulated time of one run [s]
  double min_dt = 1e-9;           ///< smallest allowed dt and dt_max [s]
  double max_dt = 1e-2;           ///< largest allowed dt and dt_max [s]
};

enum class DesignType { kGrid, kList, kRandom, kLhs, kSobol, kMorris, kEfast, kRbdFast, kDgsm };

/// What a run with F_S < F_C does (spec field "F_S_below_F_C"). kFail (default): config_for
/// throws, so the run is stored as invalid. kRaiseToFc: the run uses F_S = F_C (a flat Stribeck
/// curve, the nearest valid friction law) and raises_F_S() says so. Lets a Sobol design vary F_S
/// and F_C independently over overlapping ranges without invalidating the indices.
enum class FsBelowFc { kFail, kRaiseToFc };
const char* to_string(DesignType type) noexcept;

/// One run of a study, computed on demand by StudySpec::point().
struct DesignPoint {
  std::size_t index = 0;
  std::string model;  ///< friction model name, or "ishigami" / "sobol_g" for analytic studies
  std::vector<std::pair<std::string, double>> values;  ///< see the ordering rules above
  /// The value of a variable of this point, if it sets one.
  std::optional<double> value(std::string_view name) const;
};

/// One grid axis. Numeric values are computed on demand.
struct Axis {
  enum class Kind { kValues, kLinspace, kLogspace };
  std::string name;  ///< canonical name ("F_slip" becomes "F_C")
  Kind kind = Kind::kValues;
  std::vector<double> numbers;      ///< kValues of a numeric axis
  std::vector<std::string> models;  ///< kValues of the "model" axis
  double start = 0, stop = 0;       ///< kLinspace: ends; kLogspace: exponents of 10
  std::size_t count = 0;            ///< kLinspace / kLogspace
  bool is_model() const noexcept { return name == "model"; }
  std::size_t size() const noexcept;
  /// Numeric value k (k < size()); linspace ends are exact.
  double at(std::size_t k) const;
};

/// One sampled parameter: the unit-cube coordinate u maps onto [min, max] (log10 when log).
struct Range {
  std::string name;
  double min = 0, max = 1;
  bool log = false;
  double map(double u) const;  ///< u = 0 gives min, u = 1 gives max exactly
};

/// An explicit point of a list design.
struct ListPoint {
  std::optional<std::string> model;
  std::vector<std::pair<std::string, double>> values;  ///< sorted by name
};

/// A Sobol design's "until" rule: after its runs, the runner doubles the base sample (up to
/// n_max) while the widest total-index (ST) interval of the listed outputs exceeds max_st_width.
struct SobolUntil {
  double max_st_width = 0.1;         ///< widest allowed ST interval width [-]
  std::size_t n_max = 0;             ///< largest base sample size N
  std::vector<std::string> outputs;  ///< outputs judged; empty: the default outputs
  double confidence = 0.95;          ///< interval level of the criterion
  std::size_t resamples = 1000;      ///< bootstrap resamples of the criterion (seed 1)
};

struct Design {
  DesignType type = DesignType::kList;
  std::vector<Axis> axes;          ///< grid
  std::vector<ListPoint> points;   ///< list
  std::vector<Range> ranges;       ///< random, lhs, sobol, morris, efast, rbd_fast, dgsm
  /// random / lhs / rbd_fast: runs; sobol / dgsm: base sample size; efast: points per curve
  std::size_t n = 0;
  std::size_t trajectories = 0;    ///< morris: r
  std::size_t levels = 0;          ///< morris: p
  std::uint64_t seed = 1;          ///< every sampled design
  bool second_order = false;       ///< sobol: BA blocks too (S2): n (2d + 2) runs
  std::optional<SobolUntil> until; ///< sobol: grow until the ST intervals are narrow enough
  std::size_t harmonics = 4;       ///< efast: interference factor M
  std::size_t replicates = 4;      ///< efast: random-phase replicates
  double step = 0.01;              ///< dgsm: finite-difference step on the unit cube
  /// Sobol designs with second order or "until" lay their runs out base row by base row, so that
  /// the design can grow; plain ones keep the block layout of studies stored before (sa_sobol.h).
  bool sobol_rows_layout() const noexcept { return second_order || until.has_value(); }
  /// Runs per base row (sobol: d + 2 or 2d + 2; dgsm: d + 1; others 1).
  std::size_t runs_per_row() const noexcept;
};

class SpecBuilder;

class StudySpec {
 public:
  const std::string& name() const noexcept { return name_; }
  /// The whole spec with every default filled in (F_slip renamed F_C, analytic default ranges).
  const nlohmann::json& canonical() const noexcept { return canonical_; }
  /// canonical() as text; indent < 0 gives the compact form (stable: keys sorted).
  std::string canonical_json(int indent = -1) const;
  /// The configuration every run starts from (engine models only).
  const engine::SimConfig& base_config() const noexcept { return base_; }
  const Design& design() const noexcept { return design_; }
  const Limits& limits() const noexcept { return limits_; }
  /// Path of the measured dataset manifest as written in the spec, if any.
  const std::optional<std::string>& measured() const noexcept { return measured_; }
  /// Trace sample rate [Hz]; 0 = no traces.
  double trace_rate() const noexcept { return base_.trace.rate; }

  /// Runs of the design as written (a Sobol design with "until": its first n base rows).
  std::size_t run_count() const noexcept { return run_count_; }
  /// Runs the design may grow to: n_max base rows for a Sobol design with "until", else
  /// run_count(). Design points exist for every index below it.
  std::size_t max_run_count() const noexcept { return max_run_count_; }
  /// Run 'index' (< max_run_count(), else std::out_of_range). O(axes) time, no stored point list.
  DesignPoint point(std::size_t index) const;
  /// Names of the design variables in design order ("model" and the derived "v_a" excluded);
  /// for sampled designs these are the columns of unit_point().
  std::vector<std::string> variables() const;
  /// Unit-cube coordinates of run 'index' of a random / lhs / sobol / morris design (the rows of
  /// saltelli_design / morris_design); throws std::logic_error for grid and list designs.
  const std::vector<double>& unit_point(std::size_t index) const;

  /// The configuration of one run. Throws engine::InvalidParameter naming the field and the
  /// value when the point is invalid (a parameter outside its domain, F_S < F_C, a duration or
  /// step outside the limits, an analytic model), so the runner can store it as an invalid run.
  engine::SimConfig config_for(const DesignPoint& point) const;
  /// The spec's "F_S_below_F_C" policy.
  FsBelowFc F_S_below_F_C() const noexcept { return fs_below_fc_; }
  /// True when config_for(point) raised F_S to F_C (policy kRaiseToFc, a model that uses F_S,
  /// and the point's F_S < F_C). False for analytic studies. Throws like config_for for a point
  /// with another problem.
  bool raises_F_S(const DesignPoint& point) const;
  /// {"model": ..., "<name>": value, ...} as compact JSON with sorted keys: a stable identity of
  /// the point's parameters (its index is not included).
  std::string canonical_point_json(const DesignPoint& point) const;
  nlohmann::json point_json(const DesignPoint& point) const;

  /// True for the analytic test models (ishigami, sobol_g): no simulation, analytic_value().
  bool is_analytic() const noexcept { return !analytic_.empty(); }
  /// "ishigami", "sobol_g", or "" for friction-model studies.
  const std::string& analytic_model() const noexcept { return analytic_; }
  /// Number of inputs of the analytic model (3 for ishigami, size of a for sobol_g).
  std::size_t analytic_inputs() const noexcept;
  /// The analytic function at the point's inputs x1..xk; throws std::logic_error for
  /// friction-model studies and std::invalid_argument if an input is missing.
  double analytic_value(const DesignPoint& point) const;

 private:
  friend class SpecBuilder;
  StudySpec() = default;

  std::string name_;
  nlohmann::json canonical_;
  engine::SimConfig base_;
  Design design_;
  Limits limits_;
  std::optional<std::string> measured_;
  FsBelowFc fs_below_fc_ = FsBelowFc::kFail;
  std::size_t run_count_ = 0;
  std::size_t max_run_count_ = 0;
  std::string analytic_;                // "" for friction models
  std::vector<double> analytic_a_;      // sobol_g: a_i; ishigami: {a}
  double analytic_b_ = 0.1;             // ishigami: b
  std::shared_ptr<const std::vector<std::vector<double>>> unit_;  // sampled designs

  // The point's configuration before the F_S_below_F_C policy and validation.
  engine::SimConfig unchecked_config(const DesignPoint& point) const;
};

struct ParseResult {
  std::optional<StudySpec> spec;  ///< set only when errors is empty
  std::vector<common::SpecError> errors;
  bool ok() const noexcept { return spec.has_value(); }
};

/// Parses and validates a study; reports every problem found.
ParseResult parse_study(std::string_view json_text, const Limits& limits = {});

/// The study schema embedded at build time (schemas/study.schema.json), as text and parsed.
std::string_view study_schema_text() noexcept;
const nlohmann::json& study_schema();

}  // namespace stickslip::studies
