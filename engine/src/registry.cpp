#include "stickslip/engine/registry.h"

namespace stickslip::engine {
namespace {

template <class... Ms>
std::array<ModelTraits, sizeof...(Ms)> make_traits(ModelList<Ms...>) {
  return {ModelTraits{model_kind<Ms>, &Ms::kInfo, Ms::kParams, registry_detail::options_of<Ms>(),
                      registry_detail::constraints_of<Ms>(), Ms::kStates,
                      registry_detail::in_every_canonical_spec<Ms>()}...};
}
const std::array<ModelTraits, kModelCount> kTraits = make_traits(FrictionModels{});

}  // namespace

const ModelTraits& model_traits(ModelKind kind) {
  return kTraits.at(static_cast<std::size_t>(kind));
}

std::span<const ModelTraits> all_model_traits() noexcept { return kTraits; }

const std::vector<ModelKind>& all_models() {
  static const std::vector<ModelKind> kAll = [] {
    std::vector<ModelKind> out;
    for (const ModelTraits& t : kTraits) out.push_back(t.kind);
    return out;
  }();
  return kAll;
}

const char* to_string(ModelKind m) noexcept {
  const auto i = static_cast<std::size_t>(m);
  return i < kTraits.size() ? kTraits[i].info->name : "?";
}

std::string model_names(std::string_view separator) {
  std::string out;
  for (const ModelTraits& t : kTraits) {
    if (!out.empty()) out += separator;
    out += t.info->name;
  }
  return out;
}

std::vector<ModelKind> models_using(std::string_view name) {
  std::vector<ModelKind> out;
  for (const ModelTraits& t : kTraits) {
    bool has = false;
    for (const ParamDef& p : t.params) has = has || name == p.name;
    for (const OptionDef& o : t.options) has = has || name == o.name;
    if (has) out.push_back(t.kind);
  }
  return out;
}

ModelKind model_from_string(std::string_view name) {
  for (const ModelTraits& t : kTraits)
    if (name == t.info->name) return t.kind;
  throw InvalidParameter("model", std::string(name),
                         "unknown model; expected one of " + model_names());
}

int friction_parameter_index(std::string_view name) noexcept {
  for (std::size_t i = 0; i < kFrictionParameters.size(); ++i) {
    const ParamDef& p = kFrictionParameters[i];
    if (name == p.name || (p.alias != nullptr && name == p.alias)) return static_cast<int>(i);
  }
  return -1;
}

int friction_option_index(std::string_view name) noexcept {
  for (std::size_t i = 0; i < kFrictionOptions.size(); ++i)
    if (name == kFrictionOptions[i].name) return static_cast<int>(i);
  return -1;
}

}  // namespace stickslip::engine
