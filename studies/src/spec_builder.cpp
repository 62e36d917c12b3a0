// SpecBuilder: the base, stages, integrator, names and values, whole-spec checks.
#include "spec_builder.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <regex>

#include "stickslip/studies/outputs.h"
#include "stickslip/studies/sa_dgsm.h"
#include "stickslip/studies/sa_fast.h"
#include "stickslip/studies/sa_sobol.h"
#include "stickslip/studies/sensitivity.h"

namespace stickslip::studies {

using namespace spec_detail;

std::optional<StudySpec> SpecBuilder::build() {
  if (auto n = string_at(doc_, "name")) spec_.name_ = *n;
  read_base();
  if (analytic()) {
    reject_engine_sections();
  } else {
    read_stages();
    read_integrator();
    apply_base_shorthands();
    check_run_limits();
    read_outputs_and_measured();
  }
  read_design();
  if (!analytic()) check_base_valid();
  count_runs();
  if (!errors_.empty()) return std::nullopt;
  sample_unit_design();
  if (!errors_.empty()) return std::nullopt;
  spec_.canonical_ = canonical();
  return std::move(spec_);
}

void SpecBuilder::read_base() {
  static const json kEmpty = json::object();
  const json* base = member(doc_, "base");
  if (base == nullptr || !base->is_object()) base = &kEmpty;
  const engine::ModelKind default_model = engine::SimConfig{}.model;
  const std::string model = string_at(*base, "model").value_or(engine::to_string(default_model));
  if (model == "ishigami" || model == "sobol_g") {
    spec_.analytic_ = model;
    read_analytic_base(*base);
    return;
  }
  // An unknown model is reported by the schema; the default stands in for the other checks.
  cfg().model = is_engine_model(model) ? engine::model_from_string(model) : default_model;
  read_engine_base(*base);
}

void SpecBuilder::read_analytic_base(const json& base) {
  const bool ishigami = spec_.analytic_ == "ishigami";
  for (const auto& [key, value] : base.items())
    if (key != "model" && key != "a" && (key != "b" || !ishigami))
      errors_.add("/base/" + key, "not used by the analytic model " + spec_.analytic_);
  if (ishigami) {
    spec_.analytic_a_ = {number_at(base, "a").value_or(7.0)};
    spec_.analytic_b_ = number_at(base, "b").value_or(0.1);
    return;
  }
  const json* a = member(base, "a");
  if (a == nullptr || !a->is_array()) return;  // the schema reports it
  for (const auto& v : *a)
    if (v.is_number()) spec_.analytic_a_.push_back(v.get<double>());
}

void SpecBuilder::read_engine_base(const json& base) {
  for (const auto& name : engine_base_fields()) {
    const auto v = number_at(base, name);
    if (!v) continue;
    try {
      engine::set_parameter(cfg(), name, *v);
    } catch (const engine::InvalidParameter& e) {
      errors_.add("/base/" + name, explain(e));
    }
  }
  for (const engine::ParamDef& p : engine::kFrictionParameters) {
    if (p.alias == nullptr) continue;
    const auto v = number_at(base, p.alias);
    if (!v) continue;
    const std::string ptr = std::string("/base/") + p.alias;
    if (member(base, p.name) != nullptr) {
      errors_.add(ptr, std::string("is an alias of ") + p.name + "; give only one of them");
      continue;
    }
    try {
      engine::set_parameter(cfg(), p.alias, *v);
    } catch (const engine::InvalidParameter& e) {
      errors_.add(ptr, explain(e));
    }
  }
  for (const engine::OptionDef& o : engine::kFrictionOptions) {
    const auto choice = string_at(base, o.name);
    if (!choice) continue;  // absent, or not a string: the schema reports it
    try {
      engine::set_option(cfg(), o.name, *choice);
    } catch (const engine::InvalidParameter& e) {
      errors_.add(std::string("/base/") + o.name, explain(e));
    }
  }
  for (const char* key : {"a", "b"})
    if (member(base, key) != nullptr)
      errors_.add(std::string("/base/") + key,
                  "only used by the analytic models ishigami and sobol_g");
}

void SpecBuilder::reject_engine_sections() {
  for (const char* key : {"stages", "integrator", "outputs", "measured", "F_S_below_F_C"})
    if (member(doc_, key) != nullptr)
      errors_.add(std::string("/") + key, "not used by the analytic model " + spec_.analytic_);
}

void SpecBuilder::read_stages() {
  const json* stages = member(doc_, "stages");
  if (stages != nullptr && stages->is_array() && !stages->empty()) {  // else default / schema
    cfg().stages.clear();
    for (const auto& s : *stages) {
      engine::Stage st;
      st.duration = number_at(s, "duration").value_or(10.0);
      st.v_a = number_at(s, "v_a").value_or(0.0);
      st.f = number_at(s, "f").value_or(1500.0);
      cfg().stages.push_back(st);
    }
  }
}

void SpecBuilder::read_integrator() {
  const json* in = member(doc_, "integrator");
  if (in == nullptr || !in->is_object()) return;
  auto& opt = cfg().integrator;
  if (auto kind = string_at(*in, "kind")) {
    try {
      opt.kind = engine::integrator_from_string(*kind);
    } catch (const engine::InvalidParameter&) {  // reported by the schema
    }
  }
  opt.dt = number_at(*in, "dt").value_or(opt.dt);
  opt.rtol = number_at(*in, "rtol").value_or(opt.rtol);
  opt.atol = number_at(*in, "atol").value_or(opt.atol);
  opt.dt_max = number_at(*in, "dt_max").value_or(opt.dt_max);
  opt.max_steps = number_at(*in, "max_steps").value_or(opt.max_steps);
}

void SpecBuilder::apply_base_shorthands() {
  const json* base = member(doc_, "base");
  if (base == nullptr || !base->is_object()) return;
  std::vector<std::string> names;
  for (const auto& [key, value] : base->items())
    if (is_stage_shorthand(key)) names.push_back(key);
  names.insert(names.end(), kShorthands.begin(), kShorthands.end());
  const json* integrator = member(doc_, "integrator");
  for (const auto& name : names) {
    const auto v = number_at(*base, name);
    if (!v) continue;
    const std::string ptr = "/base/" + name;
    if (integrator != nullptr && member(*integrator, name) != nullptr) {
      errors_.add(ptr, "also given as /integrator/" + name + "; give it in one place only");
      continue;
    }
    try {
      engine::set_parameter(cfg(), name, *v);
    } catch (const engine::InvalidParameter& e) {
      errors_.add(ptr, explain(e));
    }
  }
}

// Run duration and step limits of the base configuration (per point: value_problem/config_for).
void SpecBuilder::check_run_limits() {
  const double total = cfg().total_duration();
  if (total > limits().max_duration)
    errors_.add("/stages", "total duration " + fmt(total) + " s exceeds the limit of " +
                               fmt(limits().max_duration) + " s");
  const json* base = member(doc_, "base");
  for (const char* name : {"dt", "dt_max"}) {
    const double v = engine::get_parameter(cfg(), name);
    if (v >= limits().min_dt && v <= limits().max_dt) continue;
    const bool in_base = base != nullptr && member(*base, name) != nullptr;
    errors_.add((in_base ? "/base/" : "/integrator/") + std::string(name),
                "must be within [" + fmt(limits().min_dt) + ", " + fmt(limits().max_dt) +
                    "] s, got " + fmt(v));
  }
}

void SpecBuilder::read_outputs_and_measured() {
  if (const json* out = member(doc_, "outputs")) {
    if (const json* traces = member(*out, "traces"))
      cfg().trace.rate = number_at(*traces, "rate").value_or(0.0);
  }
  spec_.measured_ = string_at(doc_, "measured");
  if (string_at(doc_, "F_S_below_F_C").value_or("fail") == "raise_F_S_to_F_C")
    spec_.fs_below_fc_ = FsBelowFc::kRaiseToFc;
}

// ---------------------------------------------------------------- names and values

bool SpecBuilder::check_name(const std::string& name, const std::string& ptr, bool allow_model) {
  if (analytic()) {
    static const std::regex kInput(R"(x([1-9][0-9]{0,5}))");
    std::smatch m;
    if (std::regex_match(name, m, kInput) && std::stoul(m[1]) <= spec_.analytic_inputs())
      return true;
    errors_.add(ptr, "unknown input " + in_quotes(name) + " of the analytic model " +
                         spec_.analytic_ + " (expected x1..x" +
                         std::to_string(spec_.analytic_inputs()) + ")");
    return false;
  }
  if (name == "model") {
    if (allow_model) return true;
    errors_.add(ptr, "\"model\" cannot be sampled from a range; use a grid axis or list points");
    return false;
  }
  if (name == "va_over_vd") return true;
  if (is_friction_option(name)) {
    errors_.add(ptr, "the model option " + in_quotes(name) +
                         " is set in \"base\"; a design cannot vary it");
    return false;
  }
  try {
    engine::get_parameter(cfg(), name);
    return true;
  } catch (const engine::InvalidParameter&) {
    std::string msg = "unknown parameter " + in_quotes(name);
    if (name.rfind("stage", 0) == 0)
      msg += " (the runs have " + std::to_string(cfg().stages.size()) + " stages)";
    errors_.add(ptr, msg);
    return false;
  }
}

std::optional<std::string> SpecBuilder::value_problem(const std::string& name, double v) const {
  if (!std::isfinite(v)) return "must be a finite number, got " + fmt(v);
  if (analytic()) return std::nullopt;
  if (name == "va_over_vd")
    return v >= 0 ? std::nullopt : std::optional<std::string>("must be >= 0, got " + fmt(v));
  engine::SimConfig c = spec_.base_;
  try {
    engine::set_parameter(c, name, v);
  } catch (const engine::InvalidParameter& e) {
    return explain(e);
  }
  if ((name == "dt" || name == "dt_max") && (v < limits().min_dt || v > limits().max_dt))
    return "must be within [" + fmt(limits().min_dt) + ", " + fmt(limits().max_dt) +
           "] s, got " + fmt(v);
  const bool sets_duration =
      name == "duration" || (name.rfind("stage", 0) == 0 && name.ends_with(".duration"));
  if (sets_duration && c.total_duration() > limits().max_duration)
    return "makes a run " + fmt(c.total_duration()) + " s long, beyond the limit of " +
           fmt(limits().max_duration) + " s";
  return std::nullopt;
}

bool SpecBuilder::check_value(const std::string& name, double v, const std::string& ptr) {
  const auto problem = value_problem(name, v);
  if (problem) errors_.add(ptr, *problem);
  return !problem;
}

// Names must be distinct (F_slip counts as F_C); v_a and va_over_vd exclude each other.
void SpecBuilder::check_names_unique(const std::vector<std::string>& names,
                                     const std::vector<std::string>& pointers, const char* what) {
  std::map<std::string, std::size_t> first;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto [it, fresh] = first.emplace(names[i], i);
    if (!fresh)
      errors_.add(pointers[i], "duplicate " + std::string(what) + " " + in_quotes(names[i]) +
                                   " (also at " + pointers[it->second] + ")");
  }
  if (first.count("v_a") != 0 && first.count("va_over_vd") != 0) {
    const std::size_t later = std::max(first["v_a"], first["va_over_vd"]);
    errors_.add(pointers[later], "give v_a or va_over_vd, not both");
  }
}

void SpecBuilder::check_inputs_covered(const std::vector<std::string>& names,
                                       const std::string& ptr) {
  if (!analytic()) return;
  std::vector<std::string> missing;
  for (std::size_t k = 1; k <= spec_.analytic_inputs(); ++k) {
    const std::string x = input_name(k);
    if (std::find(names.begin(), names.end(), x) == names.end()) missing.push_back(x);
  }
  if (!missing.empty())
    errors_.add(ptr, "missing input" + std::string(missing.size() > 1 ? "s " : " ") +
                         join(missing, ", ") + " of the analytic model " + spec_.analytic_);
}

// ---------------------------------------------------------------- designs

void SpecBuilder::check_base_valid() {
  std::set<std::string> models = design_models_;
  models.insert(to_string(cfg().model));
  for (const auto& model : models) {
    engine::SimConfig c = cfg();
    c.model = engine::model_from_string(model);
    // A field is varied when the design sets it or a field it must be at least (F_S >= F_C).
    auto varied = [&](const std::string& field) {
      auto set = [&](std::string_view f) {
        return std::find(varied_.begin(), varied_.end(), f) != varied_.end();
      };
      if (set(field)) return true;
      for (const engine::Constraint& k : engine::model_traits(c.model).constraints)
        if (field == k.param && set(k.at_least)) return true;
      return false;
    };
    std::vector<std::string> messages;
    if (c.IsValid(&messages)) continue;
    for (const auto& raw : messages) {
      const std::string m = tidy_numbers(raw);
      const auto parts = split_invalid(m);
      if (varied(parts.field)) continue;
      const std::string suffix = c.model == cfg().model ? "" : " (with model " + model + ")";
      const std::string pointer = parts.field.empty() ? pointer_for_field(m.substr(0, m.find(':')))
                                                      : pointer_for_field(parts.field);
      errors_.add(pointer, (parts.value.empty() ? parts.why : parts.why + ", got " + parts.value) +
                               suffix);
    }
  }
}

void SpecBuilder::count_runs() {
  const auto& d = spec_.design_;
  std::size_t runs = 0;
  switch (d.type) {
    case DesignType::kGrid:
      runs = d.axes.empty() ? 0 : 1;
      for (const auto& a : d.axes) runs = saturating_mul(runs, a.size());
      break;
    case DesignType::kList: runs = d.points.size(); break;
    case DesignType::kRandom:
    case DesignType::kLhs:
    case DesignType::kRbdFast: runs = d.n; break;
    case DesignType::kSobol:
    case DesignType::kDgsm: runs = saturating_mul(d.n, d.runs_per_row()); break;
    case DesignType::kMorris: runs = saturating_mul(d.trajectories, d.ranges.size() + 1); break;
    case DesignType::kEfast:
      runs = saturating_mul(saturating_mul(d.replicates, d.ranges.size()), d.n);
      break;
  }
  spec_.run_count_ = runs;
  spec_.max_run_count_ = d.until ? saturating_mul(d.until->n_max, d.runs_per_row()) : runs;
  const std::size_t most = spec_.max_run_count_;
  if (most > limits().max_runs) {
    const std::string count = most == std::numeric_limits<std::size_t>::max()
                                  ? std::string("too many")
                                  : std::to_string(most);
    errors_.add(d.until ? "/design/until/n_max" : "/design",
                count + " runs exceeds the limit of " + std::to_string(limits().max_runs));
  }
}

void SpecBuilder::sample_unit_design() {
  const auto& d = spec_.design_;
  const std::size_t dim = d.ranges.size();
  try {
    switch (d.type) {
      case DesignType::kRandom:
        spec_.unit_ = std::make_shared<const Matrix>(random_unit(d.n, dim, d.seed));
        break;
      case DesignType::kLhs:
        spec_.unit_ = std::make_shared<const Matrix>(lhs_unit(d.n, dim, d.seed));
        break;
      case DesignType::kSobol: {
        sensitivity::SaltelliShape shape;
        shape.n = d.until ? d.until->n_max : d.n;
        shape.d = dim;
        shape.second_order = d.second_order;
        shape.layout = d.sobol_rows_layout() ? sensitivity::SaltelliLayout::kRows
                                             : sensitivity::SaltelliLayout::kBlocks;
        spec_.unit_ = std::make_shared<const Matrix>(sensitivity::saltelli_rows(shape, d.seed));
        break;
      }
      case DesignType::kEfast: {
        sensitivity::EfastShape shape;
        shape.n = d.n;
        shape.d = dim;
        shape.M = d.harmonics;
        shape.replicates = d.replicates;
        spec_.unit_ = std::make_shared<const Matrix>(sensitivity::efast_design(shape, d.seed));
        break;
      }
      case DesignType::kRbdFast:
        spec_.unit_ = std::make_shared<const Matrix>(sensitivity::rbd_design(d.n, dim, d.seed));
        break;
      case DesignType::kDgsm:
        spec_.unit_ =
            std::make_shared<const Matrix>(sensitivity::dgsm_design(d.n, dim, d.step, d.seed));
        break;
      case DesignType::kMorris:
        spec_.unit_ = std::make_shared<const Matrix>(
            sensitivity::morris_design(d.trajectories, dim, d.levels, d.seed));
        break;
      default: return;
    }
  } catch (const std::exception& e) {
    errors_.add("/design", std::string("cannot build the design: ") + e.what());
    return;
  }
  if (spec_.unit_->size() != spec_.max_run_count_)
    errors_.add("/design", "the design generator returned " + std::to_string(spec_.unit_->size()) +
                               " points instead of " + std::to_string(spec_.max_run_count_));
}

}  // namespace stickslip::studies
