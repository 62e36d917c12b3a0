#pragma once
// The friction-model registry: model ids, the one dispatch from a run-time ModelKind to the
// model's type, and the traits tables as plain data for the consumers that only read them (the
// schema generator, the CLI, the spec and the diagnosis). Everything here derives from
// FrictionModels (model_list.h) and the models' own traits; nothing restates a model.
//
// The tables are checked at compile time: names unique, a parameter shared by several models
// described identically (models/contact.h), defaults inside their allowed range, fit ranges
// inside it, constraints and relative fits naming the model's own parameters.
#include <algorithm>
#include <array>
#include <string>
#include <cstddef>
#include <span>
#include <string_view>
#include <type_traits>
#include <vector>

#include "stickslip/engine/invalid_parameter.h"
#include "stickslip/engine/model_list.h"

namespace stickslip::engine {

/// A registered friction model: its position in FrictionModels.
enum class ModelKind : int {};

namespace registry_detail {

template <class M, class List>
struct IndexOf;
template <class M, class... Ms>
struct IndexOf<M, ModelList<Ms...>> {
  static constexpr int value = [] {
    constexpr bool same[] = {std::is_same_v<M, Ms>...};
    for (int i = 0; i < static_cast<int>(sizeof...(Ms)); ++i)
      if (same[i]) return i;
    return -1;
  }();
  static_assert(value >= 0, "not a registered friction model (model_list.h)");
};
template <class List>
struct Size;
template <class... Ms>
struct Size<ModelList<Ms...>> {
  static constexpr int value = sizeof...(Ms);
};

// Optional traits: absent means none.
template <class M>
constexpr std::span<const OptionDef> options_of() {
  if constexpr (requires { M::kOptions; }) return M::kOptions;
  else return {};
}
template <class M>
constexpr bool in_every_canonical_spec() {
  if constexpr (requires { M::kInEveryCanonicalSpec; }) return M::kInEveryCanonicalSpec;
  else return false;
}
template <class M>
constexpr std::span<const Constraint> constraints_of() {
  if constexpr (requires { M::kConstraints; }) return M::kConstraints;
  else return {};
}

}  // namespace registry_detail

inline constexpr int kModelCount = registry_detail::Size<FrictionModels>::value;
template <class M>
inline constexpr ModelKind model_kind =
    static_cast<ModelKind>(registry_detail::IndexOf<M, FrictionModels>::value);

/// Calls f(std::type_identity<M>{}) with the model type M that kind names and returns its result
/// (the same type for every model). The one place a run-time model id becomes a type.
template <class F>
decltype(auto) visit_model(ModelKind kind, F&& f);

/// A model's traits as plain data.
struct ModelTraits {
  ModelKind kind;
  const ModelInfo* info;
  std::span<const ParamDef> params;
  std::span<const OptionDef> options;
  std::span<const Constraint> constraints;
  int states;  ///< internal states (capacity)
  /// The study spec's canonical form (and so the hash that a stored study is resumed by)
  /// carries this model's parameters whatever models the study uses: true for the seed's four
  /// models (M::kInEveryCanonicalSpec), whose parameters every canonical form written before
  /// other models were registered holds. Other models' parameters appear only in the canonical
  /// form of a study that uses them, so registering a model changes no stored study's hash.
  bool in_every_canonical_spec;
  bool accepts(int integrator_kind) const noexcept {
    return (info->integrators >> integrator_kind) & 1u;
  }
};
/// Traits of a model; of every model in list order.
const ModelTraits& model_traits(ModelKind kind);
std::span<const ModelTraits> all_model_traits() noexcept;
/// The model ids in list order.
const std::vector<ModelKind>& all_models();
/// "lugre" ... (ModelInfo::name).
const char* to_string(ModelKind m) noexcept;
/// The model named name; throws InvalidParameter("model", name, "unknown model; expected one of
/// ...") listing the registered names.
ModelKind model_from_string(std::string_view name);
/// The registered names joined: "dahl, karnopp, reset_integrator, lugre".
std::string model_names(std::string_view separator = ", ");
/// The models whose traits table has the parameter or option name (not an alias), in list order.
std::vector<ModelKind> models_using(std::string_view name);

// ------------------------------------------------------------------ implementation

namespace registry_detail {

template <class... Ms>
consteval std::size_t row_count(ModelList<Ms...>) {
  return (std::size(Ms::kParams) + ...);
}
template <class... Ms>
consteval auto all_rows(ModelList<Ms...>) {
  std::array<ParamDef, row_count(ModelList<Ms...>{})> rows{};
  std::size_t i = 0;
  ((std::ranges::copy(Ms::kParams, rows.begin() + static_cast<std::ptrdiff_t>(i)),
    i += std::size(Ms::kParams)),
   ...);
  return rows;
}
inline constexpr auto kAllRows = all_rows(FrictionModels{});

constexpr bool eq(const char* a, const char* b) { return std::string_view(a) == b; }

consteval std::size_t unique_count() {
  std::size_t n = 0;
  for (std::size_t i = 0; i < kAllRows.size(); ++i) {
    bool first = true;
    for (std::size_t j = 0; j < i; ++j) first = first && !eq(kAllRows[j].name, kAllRows[i].name);
    n += first;
  }
  return n;
}
consteval auto unique_rows() {
  std::array<ParamDef, unique_count()> out{};
  std::size_t n = 0;
  for (std::size_t i = 0; i < kAllRows.size(); ++i) {
    bool first = true;
    for (std::size_t j = 0; j < i; ++j) first = first && !eq(kAllRows[j].name, kAllRows[i].name);
    if (first) {
      out[n] = kAllRows[i];
      out[n].fit = {};  // fits are per model
      ++n;
    }
  }
  return out;
}
// Rows of the same name describe the same parameter.
consteval bool shared_rows_agree() {
  for (std::size_t i = 0; i < kAllRows.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (eq(kAllRows[j].name, kAllRows[i].name) && !same_parameter(kAllRows[j], kAllRows[i]))
        return false;
  return true;
}
static_assert(shared_rows_agree(),
              "two models describe a parameter of the same name differently; share one "
              "ParamDef (models/contact.h) and give each model its own fit with with_fit()");

template <class M>
consteval bool own_table_sane() {
  const auto& p = M::kParams;
  auto own = [&](const char* name) {
    for (const ParamDef& q : p)
      if (eq(q.name, name)) return true;
    return false;
  };
  for (std::size_t i = 0; i < std::size(p); ++i) {
    for (std::size_t j = 0; j < i; ++j)
      if (eq(p[i].name, p[j].name)) return false;  // a name twice
    if (!p[i].allowed.contains(p[i].def)) return false;  // default outside its range
    if (p[i].fit.fitted()) {
      if (p[i].fit.relative_to == nullptr &&
          !(p[i].allowed.contains(p[i].fit.lo) && p[i].allowed.contains(p[i].fit.hi)))
        return false;  // fit range outside the allowed range
      if (p[i].fit.relative_to != nullptr && !own(p[i].fit.relative_to)) return false;
      if (p[i].fit.scale == FitScale::kLog && !(p[i].fit.lo > 0)) return false;
    }
  }
  for (const Constraint& c : constraints_of<M>())
    if (!own(c.param) || !own(c.at_least)) return false;
  return M::kStates >= 0;
}

template <class... Ms>
consteval bool tables_sane(ModelList<Ms...>) {
  constexpr const char* names[] = {Ms::kInfo.name...};
  for (std::size_t i = 0; i < sizeof...(Ms); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (eq(names[i], names[j])) return false;
  return (own_table_sane<Ms>() && ...);
}
static_assert(tables_sane(FrictionModels{}),
              "a model's traits table is inconsistent: a duplicate name, a default or fit range "
              "outside the allowed range, a log fit range not > 0, or a constraint / relative "
              "fit naming a parameter the model does not have");

template <class... Ms>
consteval auto all_option_rows(ModelList<Ms...>) {
  constexpr std::size_t n = (options_of<Ms>().size() + ... + 0);
  std::array<OptionDef, n> rows{};
  std::size_t i = 0;
  ((std::ranges::copy(options_of<Ms>(), rows.begin() + static_cast<std::ptrdiff_t>(i)),
    i += options_of<Ms>().size()),
   ...);
  return rows;
}
inline constexpr auto kAllOptionRows = all_option_rows(FrictionModels{});
consteval bool same_option(const OptionDef& a, const OptionDef& b) {
  if (!eq(a.name, b.name) || a.def != b.def || a.choices.size() != b.choices.size()) return false;
  for (std::size_t k = 0; k < a.choices.size(); ++k)
    if (!eq(a.choices[k], b.choices[k])) return false;
  return true;
}
consteval std::size_t unique_option_count() {
  std::size_t n = 0;
  for (std::size_t i = 0; i < kAllOptionRows.size(); ++i) {
    bool first = true;
    for (std::size_t j = 0; j < i; ++j) {
      if (eq(kAllOptionRows[j].name, kAllOptionRows[i].name)) {
        if (!same_option(kAllOptionRows[j], kAllOptionRows[i])) throw "option defined twice";
        first = false;
      }
    }
    for (const ParamDef& p : kAllRows)
      if (eq(p.name, kAllOptionRows[i].name)) throw "an option has a parameter's name";
    if (kAllOptionRows[i].def < 0 ||
        kAllOptionRows[i].def >= static_cast<int>(kAllOptionRows[i].choices.size()))
      throw "an option's default is not one of its choices";
    n += first;
  }
  return n;
}
consteval auto unique_option_rows() {
  std::array<OptionDef, unique_option_count()> out{};
  std::size_t n = 0;
  for (std::size_t i = 0; i < kAllOptionRows.size(); ++i) {
    bool first = true;
    for (std::size_t j = 0; j < i; ++j)
      first = first && !eq(kAllOptionRows[j].name, kAllOptionRows[i].name);
    if (first) out[n++] = kAllOptionRows[i];
  }
  return out;
}

template <class F, class... Ms>
decltype(auto) visit(ModelList<Ms...>, int index, F& f) {
  using R = decltype(f(std::type_identity<Dahl>{}));
  static constexpr R (*table[])(F&) = {+[](F& g) -> R { return g(std::type_identity<Ms>{}); }...};
  return table[index](f);
}

}  // namespace registry_detail

/// Every friction parameter of every model, once (list order, first occurrence; fit empty).
inline constexpr auto kFrictionParameters = registry_detail::unique_rows();
/// Every model option, once (list order).
inline constexpr auto kFrictionOptions = registry_detail::unique_option_rows();
/// Index of a friction parameter (or its alias) in kFrictionParameters; -1 when there is none.
int friction_parameter_index(std::string_view name) noexcept;
/// Index of a model option in kFrictionOptions; -1 when there is none.
int friction_option_index(std::string_view name) noexcept;
/// Index of M's parameter i in kFrictionParameters.
template <class M>
inline constexpr auto kParamSlots = [] {
  std::array<int, std::size(M::kParams)> out{};
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t k = 0; k < kFrictionParameters.size(); ++k)
      if (registry_detail::eq(kFrictionParameters[k].name, M::kParams[i].name))
        out[i] = static_cast<int>(k);
  return out;
}();
template <class M>
inline constexpr auto kOptionSlots = [] {
  constexpr auto own = registry_detail::options_of<M>();
  std::array<int, own.size()> out{};
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t k = 0; k < kFrictionOptions.size(); ++k)
      if (registry_detail::eq(kFrictionOptions[k].name, own[i].name)) out[i] = static_cast<int>(k);
  return out;
}();

template <class F>
decltype(auto) visit_model(ModelKind kind, F&& f) {
  return registry_detail::visit(FrictionModels{}, static_cast<int>(kind), f);
}

}  // namespace stickslip::engine
