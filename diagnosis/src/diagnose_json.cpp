// diagnosis.json (to_json; schemas/diagnosis.schema.json) and the calibrated models' form that
// `stickslip validate` reads back (calibrated_json, calibrated_from_json).
#include <cmath>

#include "stickslip/common/json_number.h"
#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/diagnosis/diagnosis_schema_data.h"

namespace stickslip::diagnosis {
namespace {

nlohmann::json params_json(const std::vector<ParamEstimate>& ps) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& p : ps) j[p.name] = {{"value", common::json_number(p.value)}, {"stderr", common::json_number(p.stderr_)}};
  return j;
}

nlohmann::json stages_json(const std::vector<StageScore>& ss, const Diagnosis& d) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& s : ss)
    a.push_back({{"run", d.run_names.at(s.run)},
                 {"stage", s.stage + 1},
                 {"amplitude", {{"measured", common::json_number(s.measured_amplitude)}, {"model", common::json_number(s.model_amplitude)}}},
                 {"mean_force", {{"measured", common::json_number(s.measured_mean)}, {"model", common::json_number(s.model_mean)}}},
                 {"mean_period", {{"measured", common::json_number(s.measured_period)}, {"model", common::json_number(s.model_period)}}},
                 {"slip_events", {{"measured", s.measured_slips}, {"model", s.model_slips}}}});
  return a;
}

nlohmann::json numbers(const std::vector<double>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (double x : v) a.push_back(common::json_number(x));
  return a;
}

nlohmann::json profiles_json(const std::vector<ResidualProfile>& ps) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& p : ps)
    j[p.variable] = {{"center", numbers(p.center)},
                     {"base", numbers(p.base)},
                     {"extended", numbers(p.extended)},
                     {"count", p.count}};
  return j;
}

nlohmann::json spectrum_json(const ResidualSpectrum& s, const char* period_name) {
  return {{period_name, numbers(s.period)}, {"base", numbers(s.base)}, {"extended", numbers(s.extended)}};
}

nlohmann::json holdout_stages_json(const RunHoldout& h) {
  nlohmann::json a = nlohmann::json::array();
  for (std::size_t i = 0; i < h.stages_base.size(); ++i) {
    const StageScore& b = h.stages_base[i];
    const StageScore* x = i < h.stages_extended.size() ? &h.stages_extended[i] : nullptr;
    auto side = [&](double m, double vb, double vx) {
      return nlohmann::json{{"measured", common::json_number(m)}, {"base", common::json_number(vb)},
                            {"extended", common::json_number(x ? vx : NAN)}};
    };
    a.push_back({{"stage", b.stage + 1},
                 {"amplitude", side(b.measured_amplitude, b.model_amplitude, x ? x->model_amplitude : NAN)},
                 {"mean_force", side(b.measured_mean, b.model_mean, x ? x->model_mean : NAN)},
                 {"mean_period", side(b.measured_period, b.model_period, x ? x->model_period : NAN)}});
  }
  return a;
}

}  // namespace

nlohmann::json stats_to_json(const SlipStats& s) {
  using common::json_number;
  return {{"duration", json_number(s.duration)},
          {"mean", json_number(s.mean)},
          {"q05", json_number(s.q05)},
          {"q95", json_number(s.q95)},
          {"spread", json_number(s.spread)},
          {"drops", s.drops},
          {"drop_median", json_number(s.drop_median)},
          {"drop_q25", json_number(s.drop_q25)},
          {"drop_q75", json_number(s.drop_q75)},
          {"rate", json_number(s.rate)},
          {"interval_median", json_number(s.interval_median)},
          {"interval_q25", json_number(s.interval_q25)},
          {"interval_q75", json_number(s.interval_q75)},
          {"interval_cv", json_number(s.interval_cv)},
          {"fall_fraction", json_number(s.fall_fraction)},
          {"ramp_slope", json_number(s.ramp_slope)},
          {"creep", json_number(s.creep)},
          {"f_peak", json_number(s.f_peak)},
          {"regime", to_string(s.regime)}};
}

namespace {

nlohmann::json comparisons_json(const std::vector<StatsComparison>& cs) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& c : cs)
    a.push_back({{"run", c.run},
                 {"stage", c.stage + 1},
                 {"part", c.held ? "held_out" : "fitted"},
                 {"measured", stats_to_json(c.measured)},
                 {"base", stats_to_json(c.base)},
                 {"extended", stats_to_json(c.extended)},
                 {"score_base", common::json_number(c.score_base)},
                 {"score_extended", common::json_number(c.score_extended)}});
  return a;
}

nlohmann::json readings_json(const Diagnosis& d) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& r : d.readings) a.push_back(reading_to_json(r));
  return a;
}

nlohmann::json adequacy_json(const Adequacy& a) {
  return {{"verdict", a.verdict},
          {"missing", a.missing},
          {"noise_floor", common::json_number(a.noise_floor)},
          {"rmse_constant_heldout", common::json_number(a.rmse_constant_heldout)},
          {"rmse_base_heldout", common::json_number(a.rmse_base_heldout)},
          {"score_constant_heldout", common::json_number(a.score_constant_heldout)},
          {"score_base_heldout", common::json_number(a.score_base_heldout)},
          {"extended_verdict", a.extended_verdict}};
}

nlohmann::json identifiability_json(const std::vector<ParamStatus>& ps) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& p : ps)
    a.push_back({{"name", p.name}, {"status", p.status}, {"value", common::json_number(p.value)}, {"why", p.why}});
  return a;
}

}  // namespace

nlohmann::json reading_to_json(const RunReading& r) {
  return {{"run", r.run},
          {"scoring", r.scoring},
          {"why", r.why},
          {"noise_sigma", common::json_number(r.noise_sigma)},
          {"noise_rho", common::json_number(r.noise_rho)},
          {"spikes", r.spikes},
          {"spike_fraction", common::json_number(r.spike_fraction)},
          {"preload", common::json_number(r.preload)},
          {"from_rest", r.from_rest},
          {"stuck_at_start", r.stuck_at_start},
          {"burn_in", common::json_number(r.burn_in)},
          {"defaulted", r.defaulted}};
}

nlohmann::json calibrated_json(const CalibratedModel& m) {
  nlohmann::json p = nlohmann::json::object();
  for (const auto& [name, value] : m.params) p[name] = common::json_number(value);
  return {{"model", engine::to_string(m.model)},
          {"effect", engine::to_string(m.effect)},
          {"params", p},
          {"offset", common::json_number(m.offset)}};
}

CalibratedModel calibrated_from_json(const nlohmann::json& j) {
  CalibratedModel m;
  if (!j.is_object()) throw std::invalid_argument("models: expected an object, got " + j.dump());
  m.model = engine::model_from_string(j.at("model").get<std::string>());
  m.effect = engine::extension_from_string(j.at("effect").get<std::string>());
  for (const auto& [name, value] : j.at("params").items()) {
    if (!value.is_number())
      throw std::invalid_argument("models: parameter " + name + " = " + value.dump() + ": not a number");
    m.params.emplace_back(name, value.get<double>());
  }
  m.offset = j.at("offset").is_number() ? j.at("offset").get<double>() : 0.0;
  return m;
}

std::string_view diagnosis_schema_text() noexcept { return generated::kDiagnosisSchemaJson; }

std::string_view evidence_view(std::string_view cause) noexcept {
  if (cause == "viscous" || cause == "stribeck_shape" || cause == "drive_damping" ||
      cause == "velocity_weakening")
    return "velocity";
  if (cause == "dwell_time" || cause == "aging") return "stick_time";
  if (cause == "drift") return "position";
  if (cause == "waviness") return "x_spectrum";
  if (cause == "sensor_dynamics") return "t_spectrum";
  if (cause == "normal_load_modulation") return "stage_levels";
  return "";
}

namespace {

nlohmann::json candidates_json(const Diagnosis& d) {
  nlohmann::json cands = nlohmann::json::array();
  for (const auto& c : d.candidates)
    cands.push_back({{"id", to_string(c.kind)},
                     {"status", c.status},
                     {"params", params_json(c.params)},
                     {"base_params", params_json(c.base_params)},
                     {"offset", common::json_number(c.offset)},
                     {"rmse_fit", common::json_number(c.rmse_fit)},
                     {"rmse_heldout", common::json_number(c.rmse_heldout)},
                     {"gain", common::json_number(c.gain)},
                     {"gain_over_noise", common::json_number(c.gain_over_noise)},
                     {"aic", common::json_number(c.aic)},
                     {"lr", common::json_number(c.lr)},
                     {"dof", c.dof},
                     {"p_value", common::json_number(c.p_value)},
                     {"p_holm", common::json_number(c.p_holm)},
                     {"size_z", common::json_number(c.size_z)},
                     {"significant", c.significant},
                     {"at_base_point", c.at_base_point},
                     {"adequacy", c.adequacy},
                     {"score_fit", common::json_number(c.score_fit)},
                     {"score_heldout", common::json_number(c.score_heldout)},
                     {"evaluations", c.evals}});
  return cands;
}

nlohmann::json evidence_json(const Diagnosis& d) {
  const Evidence& e = d.evidence;
  nlohmann::json lv = nlohmann::json::array();
  for (std::size_t i = 0; i < e.stage_mean_residual.size(); ++i)
    lv.push_back({{"va", common::json_number(e.stage_va[i])},
                  {"mean_residual", common::json_number(e.stage_mean_residual[i])},
                  {"mean_residual_extended",
                   common::json_number(i < e.stage_mean_residual_extended.size() ? e.stage_mean_residual_extended[i] : NAN)}});
  return {{"residual_rms", common::json_number(e.residual_rms)},
                   {"lag1_autocorrelation", common::json_number(e.rho)},
                   {"n_fit", common::json_number(e.n)},
                   {"n_effective", common::json_number(e.n_eff)},
                   {"corr_velocity", common::json_number(e.corr_velocity)},
                   {"corr_position", common::json_number(e.corr_position)},
                   {"corr_stick_time", common::json_number(e.corr_stick_time)},
                   {"trend_per_m", common::json_number(e.trend_per_m)},
                   {"x_spectrum_peak", {{"wavelength", common::json_number(e.wavelength)},
                                        {"amplitude", common::json_number(e.wavelength_amplitude)},
                                        {"phase", common::json_number(e.wavelength_phase)},
                                        {"power_over_median", common::json_number(e.wavelength_ratio)}}},
                   {"t_spectrum_peak", {{"frequency", common::json_number(e.frequency)},
                                        {"amplitude", common::json_number(e.frequency_amplitude)},
                                        {"power_over_median", common::json_number(e.frequency_ratio)}}},
                   {"stage_level_vs_va", lv},
                   {"extended_model", d.cause != "none" ? d.cause : d.best_candidate},
                   {"profiles", profiles_json(e.profiles)},
                   {"x_spectrum", spectrum_json(e.x_spectrum, "wavelength")},
                   {"t_spectrum", spectrum_json(e.t_spectrum, "period")},
                   {"per_stage", stages_json(e.stages, d)}};
}

nlohmann::json calibrations_json(const Diagnosis& d) {
  nlohmann::json cal = nlohmann::json::array();
  for (const auto& c : d.calibrations) {
    nlohmann::json runs = nlohmann::json::object();
    for (std::size_t k = 0; k < c.rmse_run.size(); ++k) runs[d.run_names[k]] = common::json_number(c.rmse_run[k]);
    cal.push_back({{"model", to_string(c.model)},
                   {"status", c.status},
                   {"params", params_json(c.params)},
                   {"offset", common::json_number(c.offset)},
                   {"rmse_fit", common::json_number(c.rmse_fit)},
                   {"rmse_heldout", common::json_number(c.rmse_heldout)},
                   {"rmse_run", runs},
                   {"aic", common::json_number(c.aic)},
                   {"evaluations", c.evals},
                   {"per_stage", stages_json(c.stages, d)},
                   {"score_fit", common::json_number(c.score_fit)},
                   {"score_heldout", common::json_number(c.score_heldout)},
                   {"identifiability", identifiability_json(c.identifiability)},
                   {"jacobian", {{"rank", c.jacobian_rank},
                                 {"condition", common::json_number(c.condition)},
                                 {"weakest", c.weakest}}}});
  }
  return cal;
}

nlohmann::json heldout_runs_json(const Diagnosis& d) {
  nlohmann::json folds = nlohmann::json::array();
  for (const auto& h : d.run_holdouts)
    folds.push_back({{"run", h.run},
                     {"va", common::json_number(h.va)},
                     {"status", h.status},
                     {"rmse_base", common::json_number(h.rmse_base)},
                     {"rmse_extended", common::json_number(h.rmse_extended)},
                     {"gain", common::json_number(h.gain)},
                     {"evaluations", h.evals},
                     {"per_stage", holdout_stages_json(h)},
                     {"score_base", common::json_number(h.score_base)},
                     {"score_extended", common::json_number(h.score_extended)},
                     {"statistics", comparisons_json(h.stats)},
                     {"mean_error", common::json_number(h.mean_error)},
                     {"drop_error", common::json_number(h.drop_error)},
                     {"rate_error", common::json_number(h.rate_error)},
                     {"reproduced", h.reproduced}});
  if (d.run_holdouts.empty()) return nullptr;
  return {{"rmse_base", common::json_number(d.rmse_base_heldout_runs)},
                         {"rmse_extended", common::json_number(d.rmse_extended_heldout_runs)},
                         {"gain", common::json_number(d.gain_heldout_runs)},
                         {"score_base", common::json_number(d.score_base_heldout_runs)},
                         {"score_extended", common::json_number(d.score_extended_heldout_runs)},
                         {"folds", folds}};
}

}  // namespace

nlohmann::json to_json(const Diagnosis& d) {
  nlohmann::json j;
  j["dataset"] = d.dataset;
  j["scoring"] = d.scoring;
  j["verdict"] = d.adequacy.verdict;
  j["readings"] = readings_json(d);
  j["adequacy"] = adequacy_json(d.adequacy);
  j["statistics"] = comparisons_json(d.statistics);
  j["models"] = {{"base", calibrated_json(d.base_fit)}, {"extended", calibrated_json(d.extended_fit)}};
  j["base_model"] = to_string(d.base_model);
  j["base_note"] = d.base_note;
  j["base_params"] = params_json(d.base_params);
  j["cause"] = d.cause;
  j["best_candidate"] = d.best_candidate;
  j["rmse_base_heldout"] = common::json_number(d.rmse_base_heldout);
  j["rmse_extended_heldout"] = common::json_number(d.rmse_extended_heldout);
  j["gain"] = common::json_number(d.gain);
  j["candidates"] = candidates_json(d);
  j["evidence"] = evidence_json(d);
  j["calibrations"] = calibrations_json(d);
  j["heldout_runs"] = heldout_runs_json(d);
  const auto& o = d.options;
  j["method"] = {{"scoring", d.scoring},
                 {"whole_run_holdout", o.whole_run_holdout},
                 {"max_evals_fold", o.max_evals_fold},{"fit_rate", o.fit_rate},
                 {"holdout_fraction", o.holdout_fraction},
                 {"later_stage_fit_span", o.later_stage_fit_span},
                 {"alpha", o.alpha},
                 {"min_gain", o.min_gain},
                 {"correction", "holm"},
                 {"rtol", o.rtol},
                 {"rtol_score", o.rtol_score}};
  j["seconds"] = d.seconds;
  j["evaluations"] = d.evaluations;
  return j;
}


}  // namespace stickslip::diagnosis
