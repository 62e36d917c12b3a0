// SpecBuilder: the designs (grid, list, sampled ranges, until).
#include "spec_builder.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <regex>

#include "stickslip/studies/outputs.h"

namespace stickslip::studies {

using namespace spec_detail;

namespace {

std::string unknown_model(const json& name) {
  return "unknown model " + name.dump() + " (expected one of " + engine::model_names() + ")";
}

}  // namespace

void SpecBuilder::read_design() {
  const json* design = member(doc_, "design");
  if (design == nullptr) {
    spec_.design_.type = DesignType::kList;
    spec_.design_.points = {ListPoint{}};
    check_inputs_covered({}, "/design");
    return;
  }
  const auto type = string_at(*design, "type").value_or("");
  if (type == "grid") {
    read_grid(*design);
  } else if (type == "list") {
    read_list(*design);
  } else if (type == "random") {
    read_sampled(*design, DesignType::kRandom);
  } else if (type == "lhs") {
    read_sampled(*design, DesignType::kLhs);
  } else if (type == "sobol") {
    read_sampled(*design, DesignType::kSobol);
  } else if (type == "morris") {
    read_sampled(*design, DesignType::kMorris);
  } else if (type == "efast") {
    read_sampled(*design, DesignType::kEfast);
  } else if (type == "rbd_fast") {
    read_sampled(*design, DesignType::kRbdFast);
  } else if (type == "dgsm") {
    read_sampled(*design, DesignType::kDgsm);
  } else {
    errors_.add("/design/type", "unknown design type " + in_quotes(type));  // schema covers it
  }
}

void SpecBuilder::read_grid(const json& design) {
  spec_.design_.type = DesignType::kGrid;
  const json* axes = member(design, "axes");
  if (axes == nullptr || !axes->is_array()) return;
  std::vector<std::string> names, pointers;
  for (std::size_t i = 0; i < axes->size(); ++i) {
    const std::string ptr = common::pointer_append("/design/axes", i);
    if (const auto name = string_at((*axes)[i], "name")) {
      names.push_back(canonical_name(*name));
      pointers.push_back(ptr + "/name");
    }
    if (auto axis = read_axis((*axes)[i], ptr)) spec_.design_.axes.push_back(std::move(*axis));
  }
  check_names_unique(names, pointers, "axis");
  if (names.size() == axes->size()) check_inputs_covered(names, "/design/axes");
  varied_ = names;
}

std::optional<Axis> SpecBuilder::read_axis(const json& a, const std::string& ptr) {
  const auto raw_name = string_at(a, "name");
  if (!raw_name) return std::nullopt;
  Axis axis;
  axis.name = canonical_name(*raw_name);
  if (!check_name(axis.name, ptr + "/name", true)) return std::nullopt;  // values unjudgeable
  bool ok = false;
  if (const json* values = member(a, "values")) {
    ok = read_axis_values(*values, ptr + "/values", &axis);
  } else if (member(a, "linspace") != nullptr || member(a, "logspace") != nullptr) {
    ok = read_axis_spacing(a, ptr, &axis);
  }
  if (!ok) return std::nullopt;  // reported here or by the schema
  for (const auto& m : axis.models) design_models_.insert(m);
  return axis;
}

bool SpecBuilder::read_axis_values(const json& values, const std::string& ptr, Axis* axis) {
  if (!values.is_array() || values.empty()) return false;
  bool ok = true;
  axis->kind = Axis::Kind::kValues;
  for (std::size_t k = 0; k < values.size(); ++k) {
    const json& v = values[k];
    const std::string vptr = common::pointer_append(ptr, k);
    if (axis->is_model()) {
      if (v.is_string() && is_engine_model(v.get<std::string>())) {
        axis->models.push_back(v.get<std::string>());
        continue;
      }
      ok = false;
      errors_.add(vptr, v.is_string() ? unknown_model(v)
                                      : "expected a model name (string), got " + v.dump());
    } else if (v.is_number()) {
      ok = check_value(axis->name, v.get<double>(), vptr) && ok;
      axis->numbers.push_back(v.get<double>());
    } else {
      ok = false;
      errors_.add(vptr, "expected a number, got " + v.dump());
    }
  }
  return ok;
}

bool SpecBuilder::read_axis_spacing(const json& a, const std::string& ptr, Axis* axis) {
  const bool log = member(a, "linspace") == nullptr;
  const char* key = log ? "logspace" : "linspace";
  const std::string sptr = ptr + "/" + key;
  const json& s = a[key];
  if (!s.is_array() || s.size() != 3 ||
      !std::all_of(s.begin(), s.end(), [](const json& v) { return v.is_number(); }))
    return false;  // the schema reports it
  if (axis->is_model()) {
    errors_.add(sptr, "the model axis needs \"values\" (a list of model names)");
    return false;
  }
  axis->kind = log ? Axis::Kind::kLogspace : Axis::Kind::kLinspace;
  axis->start = s[0].get<double>();
  axis->stop = s[1].get<double>();
  const double count = s[2].get<double>();
  if (!(count >= 1 && count <= 1e15 && count == std::floor(count))) {
    errors_.add(sptr + "/2", "count must be an integer >= 1, got " + s[2].dump());
    return false;
  }
  axis->count = static_cast<std::size_t>(count);
  bool ok = true;
  for (std::size_t end = 0; end < 2; ++end) {
    const double e = end == 0 ? axis->start : axis->stop;
    const double v = log ? std::pow(10.0, e) : e;
    if (log && !(std::isfinite(v) && v > 0)) {
      errors_.add(common::pointer_append(sptr, end), "10^" + fmt(e) + " is not a finite positive number");
      ok = false;
    } else if (end == 0 || axis->count > 1) {
      ok = check_value(axis->name, v, common::pointer_append(sptr, end)) && ok;
    }
  }
  return ok;
}

void SpecBuilder::read_list(const json& design) {
  spec_.design_.type = DesignType::kList;
  const json* points = member(design, "points");
  if (points == nullptr || !points->is_array()) return;
  for (std::size_t i = 0; i < points->size(); ++i) {
    if (auto p = read_point((*points)[i], common::pointer_append("/design/points", i))) {
      if (p->model) design_models_.insert(*p->model);
      for (const auto& [name, v] : p->values)
        if (std::find(varied_.begin(), varied_.end(), name) == varied_.end())
          varied_.push_back(name);
      spec_.design_.points.push_back(std::move(*p));
    }
  }
}

std::optional<ListPoint> SpecBuilder::read_point(const json& p, const std::string& ptr) {
  if (!p.is_object()) return std::nullopt;
  ListPoint point;
  bool ok = true;
  std::vector<std::string> names, pointers;
  for (const auto& [key, value] : p.items()) {
    const std::string kptr = common::pointer_append(ptr, key);
    if (key == "model" && !analytic()) {
      if (value.is_string() && is_engine_model(value.get<std::string>())) {
        point.model = value.get<std::string>();
      } else {
        ok = false;
        errors_.add(kptr, value.is_string() ? unknown_model(value)
                                            : "expected a model name (string), got " +
                                                  value.dump());
      }
      continue;
    }
    const std::string name = canonical_name(key);
    if (!check_name(name, kptr, true)) {
      ok = false;
      continue;
    }
    if (!value.is_number()) {
      ok = false;
      errors_.add(kptr, "expected a number, got " + value.dump());
      continue;
    }
    ok = check_value(name, value.get<double>(), kptr) && ok;
    point.values.emplace_back(name, value.get<double>());
    names.push_back(name);
    pointers.push_back(kptr);
  }
  check_names_unique(names, pointers, "parameter");
  check_inputs_covered(names, ptr);
  std::sort(point.values.begin(), point.values.end());
  if (!ok) return std::nullopt;
  return point;
}

std::vector<Range> SpecBuilder::default_ranges() const {
  std::vector<Range> out;
  const bool ishigami = spec_.analytic_ == "ishigami";
  for (std::size_t k = 1; k <= spec_.analytic_inputs(); ++k)
    out.push_back({input_name(k), ishigami ? -kPi : 0.0, ishigami ? kPi : 1.0, false});
  return out;
}

void SpecBuilder::read_sampled(const json& design, DesignType type) {
  auto& d = spec_.design_;
  d.type = type;
  d.seed = count_at(design, "seed").value_or(1);
  if (type == DesignType::kMorris) {
    d.trajectories = count_at(design, "trajectories").value_or(0);
    d.levels = count_at(design, "levels").value_or(4);
  } else {
    d.n = count_at(design, "n").value_or(0);
  }
  d.harmonics = count_at(design, "M").value_or(4);
  d.replicates = count_at(design, "replicates").value_or(4);
  d.step = number_at(design, "step").value_or(0.01);
  d.second_order = member(design, "second_order") != nullptr && design["second_order"] == true;
  if (type == DesignType::kEfast && d.n <= 4 * d.harmonics * d.harmonics)
    errors_.add("/design/n", "eFAST needs n > 4 M^2 = " +
                                 std::to_string(4 * d.harmonics * d.harmonics) + " (M = " +
                                 std::to_string(d.harmonics) + "), got " + std::to_string(d.n));
  if (const json* until = member(design, "until")) read_until(*until);
  const json* ranges = member(design, "ranges");
  if (ranges == nullptr) {
    if (analytic())
      d.ranges = default_ranges();
    else
      errors_.add("/design/ranges", "required for friction models (only the analytic models "
                                    "have default ranges)");
  } else if (ranges->is_array()) {
    std::vector<std::string> names, pointers;
    for (std::size_t i = 0; i < ranges->size(); ++i) {
      const std::string ptr = common::pointer_append("/design/ranges", i);
      if (const auto name = string_at((*ranges)[i], "name")) {
        names.push_back(canonical_name(*name));
        pointers.push_back(ptr + "/name");
      }
      if (auto r = read_range((*ranges)[i], ptr)) d.ranges.push_back(std::move(*r));
    }
    check_names_unique(names, pointers, "range");
    if (names.size() == ranges->size()) check_inputs_covered(names, "/design/ranges");
  }
  for (const auto& r : d.ranges) varied_.push_back(r.name);
}

std::optional<Range> SpecBuilder::read_range(const json& r, const std::string& ptr) {
  const auto name = string_at(r, "name");
  const auto lo = number_at(r, "min");
  const auto hi = number_at(r, "max");
  if (!name || !lo || !hi) return std::nullopt;  // the schema reports it
  Range range{canonical_name(*name), *lo, *hi, string_at(r, "scale").value_or("linear") == "log"};
  bool ok = check_name(range.name, ptr + "/name", false);
  if (!ok) return std::nullopt;
  if (range.min > range.max) {
    errors_.add(ptr, "min " + fmt(range.min) + " is greater than max " + fmt(range.max));
    ok = false;
  }
  if (range.log && !(range.min > 0)) {
    errors_.add(ptr + "/min", "log scale needs min > 0, got " + fmt(range.min));
    ok = false;
  }
  ok = check_value(range.name, range.min, ptr + "/min") && ok;
  ok = check_value(range.name, range.max, ptr + "/max") && ok;
  if (!ok) return std::nullopt;
  return range;
}

// ---------------------------------------------------------------- whole-spec checks

// SimConfig::IsValid of the base under every model the design uses; a constraint on a field the

void SpecBuilder::read_until(const json& until) {
  auto& d = spec_.design_;
  if (d.type != DesignType::kSobol) {
    errors_.add("/design/until", "\"until\" applies to sobol designs only");
    return;
  }
  SobolUntil u;
  u.max_st_width = number_at(until, "max_st_width").value_or(u.max_st_width);
  u.n_max = count_at(until, "n_max").value_or(0);
  u.confidence = number_at(until, "confidence").value_or(u.confidence);
  u.resamples = count_at(until, "resamples").value_or(u.resamples);
  if (u.n_max < d.n)
    errors_.add("/design/until/n_max", "n_max must be >= n = " + std::to_string(d.n) + ", got " +
                                           std::to_string(u.n_max));
  const OutputContext context{spec_.analytic_, analytic() ? 1 : cfg().stages.size()};
  if (const json* outputs = member(until, "outputs"); outputs != nullptr && outputs->is_array())
    for (std::size_t k = 0; k < outputs->size(); ++k) {
      const std::string name = (*outputs)[k].is_string() ? (*outputs)[k].get<std::string>() : "";
      std::string why;
      if (!parse_output(context, name, &why))
        errors_.add(common::pointer_append("/design/until/outputs", k), why);
      u.outputs.push_back(name);
    }
  if (u.outputs.empty()) u.outputs = default_outputs(context);
  d.until = std::move(u);
}

}  // namespace stickslip::studies
