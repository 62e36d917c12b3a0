#include "stickslip/studies/spec.h"

#include <cmath>
#include <set>
#include <stdexcept>

#include "spec_builder.h"
#include "stickslip/studies/sensitivity.h"
#include "stickslip/studies/study_schema_data.h"  // generated at build time

namespace stickslip::studies {

using namespace spec_detail;

// ---------------------------------------------------------------- public API

const char* to_string(DesignType type) noexcept {
  switch (type) {
    case DesignType::kGrid: return "grid";
    case DesignType::kList: return "list";
    case DesignType::kRandom: return "random";
    case DesignType::kLhs: return "lhs";
    case DesignType::kSobol: return "sobol";
    case DesignType::kMorris: return "morris";
    case DesignType::kEfast: return "efast";
    case DesignType::kRbdFast: return "rbd_fast";
    case DesignType::kDgsm: return "dgsm";
  }
  return "?";
}

std::optional<double> DesignPoint::value(std::string_view name) const {
  for (const auto& [n, v] : values)
    if (n == name) return v;
  return std::nullopt;
}

std::size_t Axis::size() const noexcept {
  if (kind != Kind::kValues) return count;
  return is_model() ? models.size() : numbers.size();
}

double Axis::at(std::size_t k) const {
  switch (kind) {
    case Kind::kValues: return numbers.at(k);
    case Kind::kLinspace: return linspace_at(start, stop, count, k);
    case Kind::kLogspace: return std::pow(10.0, linspace_at(start, stop, count, k));
  }
  return 0.0;
}

double Range::map(double u) const {
  if (u <= 0) return min;
  if (u >= 1) return max;
  if (!log) return min + u * (max - min);
  const double lo = std::log10(min), hi = std::log10(max);
  return std::pow(10.0, lo + u * (hi - lo));
}

std::string StudySpec::canonical_json(int indent) const { return canonical_.dump(indent); }

std::size_t StudySpec::analytic_inputs() const noexcept {
  if (analytic_ == "ishigami") return kIshigamiInputs;
  return analytic_ == "sobol_g" ? analytic_a_.size() : 0;
}

std::vector<std::string> StudySpec::variables() const {
  std::vector<std::string> out;
  switch (design_.type) {
    case DesignType::kGrid:
      for (const auto& a : design_.axes)
        if (!a.is_model()) out.push_back(a.name);
      break;
    case DesignType::kList: {
      std::set<std::string> names;
      for (const auto& p : design_.points)
        for (const auto& [n, v] : p.values) names.insert(n);
      out.assign(names.begin(), names.end());
      break;
    }
    default:
      for (const auto& r : design_.ranges) out.push_back(r.name);
  }
  return out;
}

const std::vector<double>& StudySpec::unit_point(std::size_t index) const {
  if (!unit_) throw std::logic_error("unit_point: grid and list designs have no unit-cube points");
  return unit_->at(index);
}

std::size_t Design::runs_per_row() const noexcept {
  switch (type) {
    case DesignType::kSobol: return (second_order ? 2 * ranges.size() : ranges.size()) + 2;
    case DesignType::kDgsm: return ranges.size() + 1;
    default: return 1;
  }
}

DesignPoint StudySpec::point(std::size_t index) const {
  if (index >= max_run_count_)
    throw std::out_of_range("point " + std::to_string(index) + " of a study with " +
                            std::to_string(max_run_count_) + " runs");
  DesignPoint p;
  p.index = index;
  p.model = is_analytic() ? analytic_ : to_string(base_.model);
  switch (design_.type) {
    case DesignType::kGrid: {
      std::vector<std::size_t> k(design_.axes.size());
      std::size_t rest = index;
      for (std::size_t i = design_.axes.size(); i-- > 0;) {
        k[i] = rest % design_.axes[i].size();
        rest /= design_.axes[i].size();
      }
      for (std::size_t i = 0; i < design_.axes.size(); ++i) {
        const Axis& a = design_.axes[i];
        if (a.is_model())
          p.model = a.models[k[i]];
        else
          p.values.emplace_back(a.name, a.at(k[i]));
      }
      break;
    }
    case DesignType::kList: {
      const ListPoint& lp = design_.points[index];
      if (lp.model) p.model = *lp.model;
      p.values = lp.values;
      break;
    }
    default: {
      const auto& row = (*unit_)[index];
      for (std::size_t j = 0; j < design_.ranges.size(); ++j)
        p.values.emplace_back(design_.ranges[j].name, design_.ranges[j].map(row[j]));
    }
  }
  if (const auto ratio = p.value("va_over_vd"); ratio && !is_analytic())
    p.values.emplace_back("v_a", *ratio * p.value("v_d").value_or(base_.drive.v_d));
  return p;
}

namespace {
// The F_S_below_F_C policy applies to the models that require F_S >= F_C (their kConstraints).
bool uses_static_friction(engine::ModelKind m) {
  for (const engine::Constraint& c : engine::model_traits(m).constraints)
    if (std::string_view(c.param) == "F_S" && std::string_view(c.at_least) == "F_C") return true;
  return false;
}
}  // namespace

engine::SimConfig StudySpec::unchecked_config(const DesignPoint& point) const {
  if (is_analytic())
    throw engine::InvalidParameter("model", analytic_, "is an analytic test model, not a simulation");
  engine::SimConfig c = base_;
  c.model = engine::model_from_string(point.model);
  std::optional<double> ratio, v_a;
  for (const auto& [name, v] : point.values) {
    if (name == "va_over_vd")
      ratio = v;
    else if (name == "v_a")
      v_a = v;  // applied last; derived from va_over_vd when that is present
    else
      engine::set_parameter(c, name, v);
  }
  if (ratio) {
    if (!(std::isfinite(*ratio) && *ratio >= 0))
      throw engine::InvalidParameter("va_over_vd", *ratio, "must be a finite number >= 0");
    engine::set_parameter(c, "v_a", *ratio * c.drive.v_d);
  } else if (v_a) {
    engine::set_parameter(c, "v_a", *v_a);
  }
  return c;
}

bool StudySpec::raises_F_S(const DesignPoint& point) const {
  if (is_analytic() || fs_below_fc_ != FsBelowFc::kRaiseToFc) return false;
  const engine::SimConfig c = unchecked_config(point);
  return uses_static_friction(c.model) && c.friction["F_S"] < c.friction["F_C"];
}

engine::SimConfig StudySpec::config_for(const DesignPoint& point) const {
  engine::SimConfig c = unchecked_config(point);
  if (fs_below_fc_ == FsBelowFc::kRaiseToFc && uses_static_friction(c.model) &&
      c.friction["F_S"] < c.friction["F_C"])
    c.friction["F_S"] = c.friction["F_C"];
  if (c.total_duration() > limits_.max_duration)
    throw engine::InvalidParameter("duration", c.total_duration(),
                           "exceeds the limit of " + fmt(limits_.max_duration) + " s");
  for (const auto& [name, v] : {std::pair<const char*, double>{"dt", c.integrator.dt},
                                {"dt_max", c.integrator.dt_max}})
    if (v < limits_.min_dt || v > limits_.max_dt)
      throw engine::InvalidParameter(name, v,
                             "must be within [" + fmt(limits_.min_dt) + ", " +
                                 fmt(limits_.max_dt) + "] s");
  std::vector<std::string> messages;
  if (!c.IsValid(&messages)) rethrow_as_invalid(messages.front());
  return c;
}

nlohmann::json StudySpec::point_json(const DesignPoint& point) const {
  json out = {{"model", point.model}};
  for (const auto& [name, v] : point.values) out[name] = v;
  return out;
}

std::string StudySpec::canonical_point_json(const DesignPoint& point) const {
  return point_json(point).dump();
}

double StudySpec::analytic_value(const DesignPoint& point) const {
  if (!is_analytic()) throw std::logic_error("analytic_value: not an analytic study");
  std::vector<double> x(analytic_inputs());
  for (std::size_t k = 0; k < x.size(); ++k) {
    const auto v = point.value(input_name(k + 1));
    if (!v) throw std::invalid_argument("analytic_value: the point has no x" + std::to_string(k + 1));
    x[k] = *v;
  }
  if (analytic_ == "ishigami") return sensitivity::ishigami(x, analytic_a_.front(), analytic_b_);
  return sensitivity::sobol_g(x, analytic_a_);
}

ParseResult parse_study(std::string_view json_text, const Limits& limits) {
  ParseResult result;
  const auto doc = common::parse_json(json_text, &result.errors);
  if (!doc) return result;
  auto schema_errors = study_validator().validate(*doc);
  polish_schema_errors(&schema_errors, *doc);
  result.errors.insert(result.errors.end(), schema_errors.begin(), schema_errors.end());
  const bool clean = result.errors.empty();
  auto spec = SpecBuilder(*doc, limits, &result.errors).build();
  if (clean && result.errors.empty()) result.spec = std::move(spec);
  return result;
}

std::string_view study_schema_text() noexcept { return generated::kStudySchemaJson; }

const nlohmann::json& study_schema() {
  static const json schema = json::parse(study_schema_text());
  return schema;
}

}  // namespace stickslip::studies
