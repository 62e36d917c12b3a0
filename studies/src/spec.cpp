#include "stickslip/studies/spec.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <unordered_set>
#include <stdexcept>

#include "stickslip/studies/outputs.h"
#include "stickslip/studies/sa_dgsm.h"
#include "stickslip/studies/sa_fast.h"
#include "stickslip/studies/sa_sobol.h"
#include "stickslip/studies/sensitivity.h"
#include "stickslip/studies/study_schema_data.h"  // generated at configure time

namespace stickslip::studies {
namespace {

using json = nlohmann::json;
using Matrix = std::vector<std::vector<double>>;

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kIshigamiInputs = 3;

// ---------------------------------------------------------------- small helpers

std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.15g", v);
  return buf;
}

std::string in_quotes(std::string_view s) { return "\"" + std::string(s) + "\""; }

std::string join(const std::vector<std::string>& parts, std::string_view sep) {
  std::string out;
  for (const auto& p : parts) out += (out.empty() ? "" : std::string(sep)) + p;
  return out;
}

std::size_t saturating_mul(std::size_t a, std::size_t b) {
  constexpr auto kMax = std::numeric_limits<std::size_t>::max();
  return (a != 0 && b > kMax / a) ? kMax : a * b;
}

std::string canonical_name(std::string_view name) {
  return name == "F_slip" ? "F_C" : std::string(name);
}

const json* member(const json& obj, std::string_view key) {
  if (!obj.is_object()) return nullptr;
  const auto it = obj.find(key);
  return it == obj.end() ? nullptr : &*it;
}

std::optional<double> number_at(const json& obj, std::string_view key) {
  const json* v = member(obj, key);
  return v != nullptr && v->is_number() ? std::optional<double>(v->get<double>()) : std::nullopt;
}

std::optional<std::string> string_at(const json& obj, std::string_view key) {
  const json* v = member(obj, key);
  return v != nullptr && v->is_string() ? std::optional<std::string>(v->get<std::string>())
                                        : std::nullopt;
}

// A non-negative integer member (JSON integer), as the schema requires for counts and seeds.
std::optional<std::uint64_t> count_at(const json& obj, std::string_view key) {
  const json* v = member(obj, key);
  if (v == nullptr || !(v->is_number_unsigned() || (v->is_number_integer() && v->get<long long>() >= 0)))
    return std::nullopt;
  return v->get<std::uint64_t>();
}

bool is_engine_model(std::string_view name) {
  try {
    engine::model_from_string(name);
    return true;
  } catch (const engine::InvalidParameter&) {
    return false;
  }
}

// InvalidParameter::what() is "field = value: why"; split it back into its parts.
struct InvalidParts {
  std::string field, value, why;
};

InvalidParts split_invalid(const std::string& what) {
  const auto eq = what.find(" = ");
  const auto colon = eq == std::string::npos ? std::string::npos : what.find(": ", eq + 3);
  if (colon == std::string::npos) return {"", "", what};
  return {what.substr(0, eq), what.substr(eq + 3, colon - eq - 3), what.substr(colon + 2)};
}

// The engine prints numbers with 17 digits ("8.3000000000000007"); show them with 15.
std::string tidy_numbers(const std::string& text) {
  static const std::regex kLong(R"([-+]?[0-9]+\.[0-9]{12,}(e[-+]?[0-9]+)?)");
  std::string out;
  auto begin = text.cbegin();
  for (std::sregex_iterator it(text.begin(), text.end(), kLong), end; it != end; ++it) {
    out.append(begin, (*it)[0].first);
    out += fmt(std::strtod(it->str().c_str(), nullptr));
    begin = (*it)[0].second;
  }
  out.append(begin, text.cend());
  return out;
}

std::string explain(const std::exception& e) {
  const auto parts = split_invalid(tidy_numbers(e.what()));
  return parts.value.empty() ? parts.why : parts.why + ", got " + parts.value;
}

[[noreturn]] void rethrow_as_invalid(const std::string& message) {
  const auto parts = split_invalid(message);
  if (parts.field.empty()) throw engine::InvalidParameter("config", std::string("invalid"), message);
  char* end = nullptr;
  const double v = std::strtod(parts.value.c_str(), &end);
  if (end != nullptr && *end == '\0' && !parts.value.empty())
    throw engine::InvalidParameter(parts.field, v, parts.why);
  throw engine::InvalidParameter(parts.field, parts.value, parts.why);
}

// ---------------------------------------------------------------- schema facts

const common::SchemaValidator& study_validator() {
  static const common::SchemaValidator validator(study_schema());
  return validator;
}

// Stage and integrator parameters that "base" accepts as shorthands, in the order they are
// applied (after any stage<i>.* shorthand); the canonical form moves them to their sections.
constexpr std::array<const char*, 8> kShorthands = {"t_on", "duration", "f",    "v_a",
                                                    "dt",   "rtol",     "atol", "dt_max"};

bool is_shorthand(std::string_view name) {
  return std::find(kShorthands.begin(), kShorthands.end(), name) != kShorthands.end();
}

bool is_stage_shorthand(const std::string& name) {
  static const std::regex kStage(R"(stage[1-9][0-9]*\.(duration|v_a|f))");
  return std::regex_match(name, kStage);
}

// The physical engine parameters of "base": the schema's list minus model, the F_slip alias,
// the analytic coefficients and the shorthands.
const std::vector<std::string>& engine_base_fields() {
  static const std::vector<std::string> fields = [] {
    std::vector<std::string> out;
    for (const auto& [name, sub] : study_schema()["$defs"]["base"]["properties"].items())
      if (name != "model" && name != "F_slip" && name != "a" && name != "b" &&
          !is_shorthand(name))
        out.push_back(name);
    return out;
  }();
  return fields;
}

bool is_base_field(std::string_view name) {
  const auto& f = engine_base_fields();
  return std::find(f.begin(), f.end(), name) != f.end();
}

// Where a SimConfig::IsValid message about 'field' points in the spec.
std::string pointer_for_field(const std::string& field) {
  if (is_base_field(field)) return "/base/" + field;
  static const std::regex kStage(R"(stage([0-9]+)\.(duration|v_a|f))");
  std::smatch m;
  if (std::regex_match(field, m, kStage))
    return "/stages/" + std::to_string(std::stoul(m[1]) - 1) + "/" + m[2].str();
  for (const char* f : {"dt", "rtol", "atol", "dt_max", "max_steps"})
    if (field == f) return "/integrator/" + field;
  if (field == "trace_rate") return "/outputs/traces/rate";
  if (field == "stages") return "/stages";
  return "/base";
}

// ---------------------------------------------------------------- deterministic sampling

class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double unit() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  // [0, 1)

 private:
  std::uint64_t state_;
};

Matrix random_unit(std::size_t n, std::size_t d, std::uint64_t seed) {
  SplitMix64 rng(seed);
  Matrix out(n, std::vector<double>(d));
  for (auto& row : out)
    for (auto& u : row) u = rng.unit();
  return out;
}

// Latin hypercube: column j puts exactly one point in each bin [k/n, (k+1)/n), strictly inside.
Matrix lhs_unit(std::size_t n, std::size_t d, std::uint64_t seed) {
  SplitMix64 rng(seed ^ 0x4C48535F4C485321ull);
  constexpr double kMargin = 0x1.0p-30;
  Matrix out(n, std::vector<double>(d));
  std::vector<std::size_t> perm(n);
  for (std::size_t j = 0; j < d; ++j) {
    for (std::size_t i = 0; i < n; ++i) perm[i] = i;
    for (std::size_t i = n; i > 1; --i) std::swap(perm[i - 1], perm[rng.next() % i]);
    for (std::size_t i = 0; i < n; ++i) {
      const double jitter = kMargin + rng.unit() * (1.0 - 2.0 * kMargin);
      out[i][j] = (static_cast<double>(perm[i]) + jitter) / static_cast<double>(n);
    }
  }
  return out;
}

double linspace_at(double start, double stop, std::size_t count, std::size_t k) {
  if (count <= 1 || k == 0) return start;
  if (k + 1 == count) return stop;
  return start + (stop - start) * static_cast<double>(k) / static_cast<double>(count - 1);
}

// ---------------------------------------------------------------- error sink

class Errors {
 public:
  explicit Errors(std::vector<common::SpecError>* out) : out_(out) {
    for (const auto& e : *out_) seen_.insert(e.pointer);
  }
  // Adds an error unless one is already reported at the same pointer (a set, not a scan of the
  // list: a design of 100,000 bad points reports its errors in linear time).
  void add(std::string pointer, std::string message) {
    if (seen_.insert(pointer).second) out_->push_back({std::move(pointer), std::move(message)});
  }
  bool empty() const noexcept { return out_->empty(); }

 private:
  std::vector<common::SpecError>* out_;
  std::unordered_set<std::string> seen_;
};

const json* find_pointer(const json& doc, const std::string& pointer) {
  try {
    const json::json_pointer p(pointer);
    return doc.contains(p) ? &doc.at(p) : nullptr;
  } catch (const json::exception&) {
    return nullptr;
  }
}

// Makes the schema's generic messages specific where the study knows more.
void polish_schema_errors(std::vector<common::SpecError>* errors, const json& doc) {
  static const std::regex kAxis(R"(/design/axes/([0-9]+))");
  static const std::regex kAxisValues(R"(/design/axes/([0-9]+)/values)");
  std::vector<common::SpecError> out;
  for (auto e : *errors) {
    const json* v = find_pointer(doc, e.pointer);
    if (std::regex_match(e.pointer, kAxisValues)) {
      if (v != nullptr && v->is_array() && v->empty()) e.message = "axis is empty";
    } else if (std::regex_match(e.pointer, kAxis) && v != nullptr && v->is_object() &&
               e.message.find(" fields, got ") != std::string::npos) {
      std::vector<std::string> kinds;
      for (const char* k : {"values", "linspace", "logspace"})
        if (v->contains(k)) kinds.push_back(in_quotes(k));
      if (kinds.size() == 1) continue;  // only the name is missing: reported on its own
      e.message = "an axis needs exactly one of \"values\", \"linspace\", \"logspace\", got " +
                  (kinds.empty() ? std::string("none") : join(kinds, " and "));
    }
    out.push_back(std::move(e));
  }
  *errors = std::move(out);
}

}  // namespace

// ---------------------------------------------------------------- SpecBuilder

class SpecBuilder {
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
  Errors errors_;
  StudySpec spec_;
  std::vector<std::string> varied_;       // canonical names the design sets
  std::set<std::string> design_models_;   // models named by the design
};

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
  const std::string model = string_at(*base, "model").value_or("lugre");
  if (model == "ishigami" || model == "sobol_g") {
    spec_.analytic_ = model;
    read_analytic_base(*base);
    return;
  }
  cfg().model = is_engine_model(model) ? engine::model_from_string(model)
                                        : engine::model_kind<engine::LuGre>;
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
  if (const auto v = number_at(base, "F_slip")) {
    if (member(base, "F_C") != nullptr) {
      errors_.add("/base/F_slip", "is an alias of F_C; give only one of them");
    } else {
      try {
        engine::set_parameter(cfg(), "F_slip", *v);
      } catch (const engine::InvalidParameter& e) {
        errors_.add("/base/F_slip", explain(e));
      }
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
    const std::string x = "x" + std::to_string(k);
    if (std::find(names.begin(), names.end(), x) == names.end()) missing.push_back(x);
  }
  if (!missing.empty())
    errors_.add(ptr, "missing input" + std::string(missing.size() > 1 ? "s " : " ") +
                         join(missing, ", ") + " of the analytic model " + spec_.analytic_);
}

// ---------------------------------------------------------------- designs

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
      errors_.add(vptr, v.is_string() ? "unknown model " + v.dump() +
                                            " (expected one of dahl, karnopp, reset_integrator, "
                                            "lugre)"
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
        errors_.add(kptr, value.is_string() ? "unknown model " + value.dump() +
                                                  " (expected one of dahl, karnopp, "
                                                  "reset_integrator, lugre)"
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
    out.push_back({"x" + std::to_string(k), ishigami ? -kPi : 0.0, ishigami ? kPi : 1.0, false});
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
// design varies is left to the runs (config_for rejects the bad points).
void SpecBuilder::check_base_valid() {
  std::set<std::string> models = design_models_;
  models.insert(to_string(cfg().model));
  auto varied = [&](const std::string& field) {
    return std::find(varied_.begin(), varied_.end(), field) != varied_.end() ||
           (field == "F_S" && std::find(varied_.begin(), varied_.end(), "F_C") != varied_.end());
  };
  for (const auto& model : models) {
    engine::SimConfig c = cfg();
    c.model = engine::model_from_string(model);
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

// ---------------------------------------------------------------- canonical form

json SpecBuilder::design_json() const {
  const auto& d = spec_.design_;
  json out = {{"type", to_string(d.type)}};
  auto ranges = [&] {
    json arr = json::array();
    for (const auto& r : d.ranges)
      arr.push_back({{"name", r.name}, {"min", r.min}, {"max", r.max},
                     {"scale", r.log ? "log" : "linear"}});
    return arr;
  };
  switch (d.type) {
    case DesignType::kGrid: {
      json axes = json::array();
      for (const auto& a : d.axes) {
        json ax = {{"name", a.name}};
        if (a.kind == Axis::Kind::kValues)
          ax["values"] = a.is_model() ? json(a.models) : json(a.numbers);
        else
          ax[a.kind == Axis::Kind::kLinspace ? "linspace" : "logspace"] = {a.start, a.stop,
                                                                           a.count};
        axes.push_back(std::move(ax));
      }
      out["axes"] = std::move(axes);
      return out;
    }
    case DesignType::kList: {
      json points = json::array();
      for (const auto& p : d.points) {
        json o = json::object();
        if (p.model) o["model"] = *p.model;
        for (const auto& [name, v] : p.values) o[name] = v;
        points.push_back(std::move(o));
      }
      out["points"] = std::move(points);
      return out;
    }
    case DesignType::kMorris:
      out["trajectories"] = d.trajectories;
      out["levels"] = d.levels;
      break;
    case DesignType::kEfast:
      out["n"] = d.n;
      out["M"] = d.harmonics;
      out["replicates"] = d.replicates;
      break;
    case DesignType::kDgsm:
      out["n"] = d.n;
      out["step"] = d.step;
      break;
    case DesignType::kSobol:
      out["n"] = d.n;
      // Written only when set, so the canonical form (and the spec hash that resume and the
      // nightly report's reuse key on) of every Sobol study written before them is unchanged.
      if (d.second_order) out["second_order"] = true;
      if (d.until)
        out["until"] = {{"max_st_width", d.until->max_st_width}, {"n_max", d.until->n_max},
                        {"outputs", d.until->outputs}, {"confidence", d.until->confidence},
                        {"resamples", d.until->resamples}};
      break;
    default:
      out["n"] = d.n;
      break;
  }
  out["seed"] = d.seed;
  out["ranges"] = ranges();
  return out;
}

json SpecBuilder::canonical() const {
  json out = {{"name", spec_.name_}};
  if (auto desc = string_at(doc_, "description")) out["description"] = *desc;
  out["design"] = design_json();
  if (analytic()) {
    json base = {{"model", spec_.analytic_}};
    if (spec_.analytic_ == "ishigami") {
      base["a"] = spec_.analytic_a_.front();
      base["b"] = spec_.analytic_b_;
    } else {
      base["a"] = spec_.analytic_a_;
    }
    out["base"] = std::move(base);
    return out;
  }
  const engine::SimConfig& c = spec_.base_;
  json base = {{"model", to_string(c.model)}};
  for (const auto& name : engine_base_fields()) base[name] = engine::get_parameter(c, name);
  out["base"] = std::move(base);
  json stages = json::array();
  for (const auto& s : c.stages)
    stages.push_back({{"duration", s.duration}, {"v_a", s.v_a}, {"f", s.f}});
  out["stages"] = std::move(stages);
  const auto& in = c.integrator;
  out["integrator"] = {{"kind", to_string(in.kind)}, {"dt", in.dt},         {"rtol", in.rtol},
                       {"atol", in.atol},            {"dt_max", in.dt_max}, {"max_steps", in.max_steps}};
  out["outputs"] = json::object();
  if (c.trace.rate > 0) out["outputs"]["traces"] = {{"rate", c.trace.rate}};
  if (spec_.measured_) out["measured"] = *spec_.measured_;
  // Only when not the default, so the canonical form (and the spec hash that resume and the
  // nightly report's reuse key on) of every study written before this field existed is unchanged.
  if (spec_.fs_below_fc_ == FsBelowFc::kRaiseToFc) out["F_S_below_F_C"] = "raise_F_S_to_F_C";
  return out;
}

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
bool uses_static_friction(engine::ModelKind m) {
  return m == engine::model_kind<engine::LuGre> || m == engine::model_kind<engine::Karnopp>;
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
    const auto v = point.value("x" + std::to_string(k + 1));
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
