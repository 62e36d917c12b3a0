#pragma once
// Helpers of the study-spec parser (spec_builder.h): JSON member access, number and message
// formatting, the error sink, the facts the schema gives (base fields, shorthands) and the
// deterministic unit-cube samplers of random and lhs designs. Internal to stickslip_studies.
#include <array>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_set>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/common/json_schema.h"
#include "stickslip/studies/spec.h"

namespace stickslip::studies::spec_detail {

using json = nlohmann::json;
using Matrix = std::vector<std::vector<double>>;

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr std::size_t kIshigamiInputs = 3;

// ---------------------------------------------------------------- small helpers

/// "%.15g".
std::string fmt(double v);
std::string in_quotes(std::string_view s);
std::string join(const std::vector<std::string>& parts, std::string_view sep);
/// a * b, or SIZE_MAX when that overflows.
std::size_t saturating_mul(std::size_t a, std::size_t b);
/// The friction parameter (registry) that name is an alias of (F_slip: F_C), or nullptr.
const engine::ParamDef* aliased_parameter(std::string_view name);
/// The parameter's own name for an alias (F_slip -> F_C); other names unchanged.
std::string canonical_name(std::string_view name);
/// True for a model option of the registry (a named choice such as a law, not a number).
bool is_friction_option(std::string_view name);
/// The member key of obj, or nullptr (also when obj is not an object).
const json* member(const json& obj, std::string_view key);
std::optional<double> number_at(const json& obj, std::string_view key);
std::optional<std::string> string_at(const json& obj, std::string_view key);
/// A non-negative integer member (JSON integer), as the schema requires for counts and seeds.
std::optional<std::uint64_t> count_at(const json& obj, std::string_view key);
/// "x<k>", the analytic models' input k.
std::string input_name(std::size_t k);
/// True for a registered friction model's id.
bool is_engine_model(std::string_view name);

/// InvalidParameter::what() is "field = value: why"; split it back into its parts.
struct InvalidParts {
  std::string field, value, why;
};
InvalidParts split_invalid(const std::string& what);
/// The engine prints numbers with 17 digits ("8.3000000000000007"); shows them with 15.
std::string tidy_numbers(const std::string& text);
/// "why, got value" of an InvalidParameter.
std::string explain(const std::exception& e);
/// Throws an InvalidParameter rebuilt from an IsValid message "field = value: why".
[[noreturn]] void rethrow_as_invalid(const std::string& message);

// ---------------------------------------------------------------- schema facts

const common::SchemaValidator& study_validator();
// Stage and integrator parameters that "base" accepts as shorthands, in the order they are
// applied (after any stage<i>.* shorthand); the canonical form moves them to their sections.
constexpr std::array<const char*, 8> kShorthands = {"t_on", "duration", "f",    "v_a",
                                                    "dt",   "rtol",     "atol", "dt_max"};

bool is_shorthand(std::string_view name);
bool is_stage_shorthand(const std::string& name);
/// The numeric engine parameters of "base": the schema's list minus model, the analytic
/// coefficients, the shorthands and the registry's aliases and model options.
const std::vector<std::string>& engine_base_fields();
bool is_base_field(std::string_view name);
/// Where a SimConfig::IsValid message about 'field' points in the spec.
std::string pointer_for_field(const std::string& field);

// ---------------------------------------------------------------- deterministic sampling

/// n x d independent uniform points in [0, 1) (SplitMix64 from seed).
Matrix random_unit(std::size_t n, std::size_t d, std::uint64_t seed);
/// Latin hypercube: column j puts exactly one point in each bin [k/n, (k+1)/n), strictly inside.
Matrix lhs_unit(std::size_t n, std::size_t d, std::uint64_t seed);
/// Point k of count points from start to stop (exact ends).
double linspace_at(double start, double stop, std::size_t count, std::size_t k);

// ---------------------------------------------------------------- errors

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

/// Makes the schema's generic messages specific where the study knows more.
void polish_schema_errors(std::vector<common::SpecError>* errors, const json& doc);

}  // namespace stickslip::studies::spec_detail
