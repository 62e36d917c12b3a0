#pragma once
// The study-spec parser: SpecBuilder reads a schema-valid (or not) study document into a
// StudySpec and reports every problem with a JSON pointer. spec_builder.cpp: the base, stages,
// integrator, names and values, whole-spec checks and the sampled unit design; spec_design.cpp:
// the designs; spec_canonical.cpp: the canonical form.
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "spec_support.h"
#include "stickslip/studies/spec.h"

namespace stickslip::studies {

class SpecBuilder {
  using json = nlohmann::json;

 public:
  SpecBuilder(const json& doc, const Limits& limits, std::vector<common::SpecError>* errors)
      : doc_(doc), errors_(errors) {
    spec_.limits_ = limits;
  }

  std::optional<StudySpec> build();

 private:
  const Limits& limits() const { return spec_.limits_; }
  engine::SimConfig& cfg() { return spec_.base_; }
  bool analytic() const { return !spec_.analytic_.empty(); }

  void read_base();
  void read_analytic_base(const json& base);
  void read_engine_base(const json& base);
  void read_stages();
  void read_integrator();
  void apply_base_shorthands();
  void check_run_limits();
  void read_outputs_and_measured();
  void reject_engine_sections();
  void read_design();
  void read_grid(const json& design);
  void read_list(const json& design);
  void read_sampled(const json& design, DesignType type);
  void read_until(const json& until);
  std::optional<Axis> read_axis(const json& a, const std::string& ptr);
  bool read_axis_values(const json& values, const std::string& ptr, Axis* axis);
  bool read_axis_spacing(const json& spec, const std::string& ptr, Axis* axis);
  std::optional<ListPoint> read_point(const json& p, const std::string& ptr);
  std::optional<Range> read_range(const json& r, const std::string& ptr);
  std::vector<Range> default_ranges() const;
  void check_names_unique(const std::vector<std::string>& names,
                          const std::vector<std::string>& pointers, const char* what);
  void check_inputs_covered(const std::vector<std::string>& names, const std::string& ptr);
  bool check_name(const std::string& name, const std::string& ptr, bool allow_model);
  bool check_value(const std::string& name, double v, const std::string& ptr);
  std::optional<std::string> value_problem(const std::string& name, double v) const;
  void check_base_valid();
  void count_runs();
  void sample_unit_design();
  json canonical() const;
  json design_json() const;

  const json& doc_;
  spec_detail::Errors errors_;
  StudySpec spec_;
  std::vector<std::string> varied_;       // canonical names the design sets
  std::set<std::string> design_models_;   // models named by the design
};

}  // namespace stickslip::studies
