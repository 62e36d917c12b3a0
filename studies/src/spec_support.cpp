// Helpers of the study-spec parser (spec_support.h).
#include "spec_support.h"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <regex>

namespace stickslip::studies::spec_detail {

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

const engine::ParamDef* aliased_parameter(std::string_view name) {
  for (const engine::ParamDef& p : engine::kFrictionParameters)
    if (p.alias != nullptr && name == p.alias) return &p;
  return nullptr;
}

std::string canonical_name(std::string_view name) {
  const engine::ParamDef* p = aliased_parameter(name);
  return p != nullptr ? std::string(p->name) : std::string(name);
}

bool is_friction_option(std::string_view name) {
  return engine::friction_option_index(name) >= 0;
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

std::string input_name(std::size_t k) {
  std::string name = "x";  // appended: "x" + std::to_string(k) makes GCC 12 report a false
  name += std::to_string(k);  // -Wrestrict (GCC bug 105329) where it is inlined
  return name;
}

bool is_engine_model(std::string_view name) {
  try {
    engine::model_from_string(name);
    return true;
  } catch (const engine::InvalidParameter&) {
    return false;
  }
}

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

bool is_shorthand(std::string_view name) {
  return std::find(kShorthands.begin(), kShorthands.end(), name) != kShorthands.end();
}

bool is_stage_shorthand(const std::string& name) {
  static const std::regex kStage(R"(stage[1-9][0-9]*\.(duration|v_a|f))");
  return std::regex_match(name, kStage);
}

const std::vector<std::string>& engine_base_fields() {
  static const std::vector<std::string> fields = [] {
    std::vector<std::string> out;
    for (const auto& [name, sub] : study_schema()["$defs"]["base"]["properties"].items())
      if (name != "model" && name != "a" && name != "b" && !is_shorthand(name) &&
          aliased_parameter(name) == nullptr && !is_friction_option(name))
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

namespace {

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

}  // namespace

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


namespace {

const json* find_pointer(const json& doc, const std::string& pointer) {
  try {
    const json::json_pointer p(pointer);
    return doc.contains(p) ? &doc.at(p) : nullptr;
  } catch (const json::exception&) {
    return nullptr;
  }
}

}  // namespace

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

}  // namespace stickslip::studies::spec_detail
