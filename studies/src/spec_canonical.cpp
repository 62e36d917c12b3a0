// SpecBuilder: the canonical form of a study (every default filled in, keys sorted).
#include "spec_builder.h"

#include <algorithm>
#include <string_view>
#include <vector>


namespace stickslip::studies {

using namespace spec_detail;

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

namespace {

/// The models a study uses: its base model and every model its design names.
std::vector<engine::ModelKind> used_models(const engine::SimConfig& base, const Design& d) {
  std::vector<engine::ModelKind> out{base.model};
  auto add = [&](const std::string& name) {
    const engine::ModelKind k = engine::model_from_string(name);
    if (std::find(out.begin(), out.end(), k) == out.end()) out.push_back(k);
  };
  for (const auto& a : d.axes)
    if (a.is_model())
      for (const auto& m : a.models) add(m);
  for (const auto& p : d.points)
    if (p.model) add(*p.model);
  return out;
}

/// Whether the canonical form carries the friction parameter or option `name`: when a model
/// the study uses has it, or a model whose parameters every canonical form carries
/// (ModelTraits::in_every_canonical_spec, the seed's four). So registering a model changes the
/// canonical form, and the hash a stored study is resumed by, of no study that does not use it.
/// Names that are not friction parameters or options (m, k_d, F_z ...) are always carried.
bool carried(std::string_view name, const std::vector<engine::ModelKind>& used) {
  bool friction = false;
  for (const engine::ModelTraits& t : engine::all_model_traits()) {
    bool has = false;
    for (const engine::ParamDef& p : t.params) has = has || name == p.name;
    for (const engine::OptionDef& o : t.options) has = has || name == o.name;
    if (!has) continue;
    friction = true;
    if (t.in_every_canonical_spec ||
        std::find(used.begin(), used.end(), t.kind) != used.end())
      return true;
  }
  return !friction;
}

}  // namespace

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
  const std::vector<engine::ModelKind> used = used_models(c, spec_.design_);
  for (const auto& name : engine_base_fields())
    if (carried(name, used)) base[name] = engine::get_parameter(c, name);
  for (const engine::OptionDef& o : engine::kFrictionOptions)
    if (carried(o.name, used)) base[o.name] = engine::get_option(c, o.name);
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

}  // namespace stickslip::studies
