// diagnosis.json, the stdout summary and the gnuplot plots of a Diagnosis.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "stickslip/common/gnuplot.h"
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

/// s as a single-quoted gnuplot string (no escapes inside; a quote is doubled), so that run
/// names from a user's manifest cannot break the plot script.
std::string gp_str(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

/// The evidence views in the order of evidence.png's panels (1 to 6).
constexpr std::string_view kEvidenceViews[] = {"velocity",   "stick_time", "position",
                                               "x_spectrum", "t_spectrum", "stage_levels"};

/// The evidence panel that points at a cause (write_report's evidence.png), 0 when none.
int evidence_panel(const std::string& cause) {
  const std::string_view view = evidence_view(cause);
  for (int i = 0; i < 6; ++i)
    if (kEvidenceViews[i] == view) return i + 1;
  return 0;
}

}  // namespace

std::string_view diagnosis_schema_text() noexcept { return generated::kDiagnosisSchemaJson; }

std::string_view evidence_view(std::string_view cause) noexcept {
  if (cause == "viscous" || cause == "stribeck_shape" || cause == "drive_damping") return "velocity";
  if (cause == "dwell_time") return "stick_time";
  if (cause == "drift") return "position";
  if (cause == "waviness") return "x_spectrum";
  if (cause == "sensor_dynamics") return "t_spectrum";
  if (cause == "normal_load_modulation") return "stage_levels";
  return "";
}

nlohmann::json to_json(const Diagnosis& d) {
  nlohmann::json j;
  j["dataset"] = d.dataset;
  j["base_model"] = to_string(d.base_model);
  j["base_params"] = params_json(d.base_params);
  j["cause"] = d.cause;
  j["best_candidate"] = d.best_candidate;
  j["rmse_base_heldout"] = common::json_number(d.rmse_base_heldout);
  j["rmse_extended_heldout"] = common::json_number(d.rmse_extended_heldout);
  j["gain"] = common::json_number(d.gain);
  auto& cands = j["candidates"] = nlohmann::json::array();
  for (const auto& c : d.candidates)
    cands.push_back({{"id", to_string(c.kind)},
                     {"status", c.status},
                     {"params", params_json(c.params)},
                     {"base_params", params_json(c.base_params)},
                     {"offset", common::json_number(c.offset)},
                     {"rmse_fit", common::json_number(c.rmse_fit)},
                     {"rmse_heldout", common::json_number(c.rmse_heldout)},
                     {"gain", common::json_number(c.gain)},
                     {"aic", common::json_number(c.aic)},
                     {"lr", common::json_number(c.lr)},
                     {"dof", c.dof},
                     {"p_value", common::json_number(c.p_value)},
                     {"p_holm", common::json_number(c.p_holm)},
                     {"significant", c.significant},
                     {"at_base_point", c.at_base_point},
                     {"evaluations", c.evals}});
  const Evidence& e = d.evidence;
  nlohmann::json lv = nlohmann::json::array();
  for (std::size_t i = 0; i < e.stage_mean_residual.size(); ++i)
    lv.push_back({{"va", common::json_number(e.stage_va[i])},
                  {"mean_residual", common::json_number(e.stage_mean_residual[i])},
                  {"mean_residual_extended",
                   common::json_number(i < e.stage_mean_residual_extended.size() ? e.stage_mean_residual_extended[i] : NAN)}});
  j["evidence"] = {{"residual_rms", common::json_number(e.residual_rms)},
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
  auto& cal = j["calibrations"] = nlohmann::json::array();
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
                   {"per_stage", stages_json(c.stages, d)}});
  }
  nlohmann::json folds = nlohmann::json::array();
  for (const auto& h : d.run_holdouts)
    folds.push_back({{"run", h.run},
                     {"va", common::json_number(h.va)},
                     {"status", h.status},
                     {"rmse_base", common::json_number(h.rmse_base)},
                     {"rmse_extended", common::json_number(h.rmse_extended)},
                     {"gain", common::json_number(h.gain)},
                     {"evaluations", h.evals},
                     {"per_stage", holdout_stages_json(h)}});
  if (d.run_holdouts.empty())
    j["heldout_runs"] = nullptr;
  else
    j["heldout_runs"] = {{"rmse_base", common::json_number(d.rmse_base_heldout_runs)},
                         {"rmse_extended", common::json_number(d.rmse_extended_heldout_runs)},
                         {"gain", common::json_number(d.gain_heldout_runs)},
                         {"folds", folds}};
  const auto& o = d.options;
  j["method"] = {{"whole_run_holdout", o.whole_run_holdout},
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

std::string summary_text(const Diagnosis& d) {
  std::ostringstream s;
  char line[256];
  s << "dataset " << d.dataset << ": " << d.run_names.size() << " run(s), diagnosed in ";
  std::snprintf(line, sizeof line, "%.1f s (%d model evaluations)\n", d.seconds, d.evaluations);
  s << line;
  s << "calibration (RMSE [N]; held-out = last part of every stage):\n";
  s << "  model             held-out    fit   per run\n";
  for (const auto& c : d.calibrations) {
    std::snprintf(line, sizeof line, "  %-16s %8.4f %8.4f  ", to_string(c.model), c.rmse_heldout, c.rmse_fit);
    s << line;
    for (double r : c.rmse_run) {
      std::snprintf(line, sizeof line, " %.4f", r);
      s << line;
    }
    if (c.status != "ok") s << "  " << c.status;
    s << "\n";
  }
  s << "best base model: " << to_string(d.base_model) << " (";
  for (std::size_t i = 0; i < d.base_params.size(); ++i) {
    std::snprintf(line, sizeof line, "%s%s = %.4g", i ? ", " : "", d.base_params[i].name.c_str(), d.base_params[i].value);
    s << line;
  }
  s << ")\ncandidates (held-out RMSE, gain, Holm p):\n";
  for (const auto& c : d.candidates) {
    std::snprintf(line, sizeof line, "  %-24s %8.4f %+7.3f  p=%.2g%s", to_string(c.kind), c.rmse_heldout, c.gain, c.p_holm,
                  c.significant ? "  significant" : "");
    s << line;
    if (!c.params.empty()) {
      std::snprintf(line, sizeof line, "  %s = %.4g +- %.2g", c.params[0].name.c_str(), c.params[0].value, c.params[0].stderr_);
      s << line;
    }
    if (c.status != "ok") s << "  " << c.status;
    s << "\n";
  }
  std::snprintf(line, sizeof line, "cause: %s  (held-out RMSE %.4f -> %.4f N, gain %.3f)\n", d.cause.c_str(),
                d.rmse_base_heldout, d.rmse_extended_heldout, d.gain);
  s << line;
  if (!d.run_holdouts.empty()) {
    s << "whole runs held out (refitted on the other runs; RMSE over the run left out [N]):\n";
    s << "  run                      v_a [m/s]      base  extended    gain\n";
    for (const auto& h : d.run_holdouts) {
      std::snprintf(line, sizeof line, "  %-24s %9.3g  %8.4f  %8.4f  %+6.3f", h.run.c_str(), h.va, h.rmse_base,
                    h.rmse_extended, h.gain);
      s << line;
      if (h.status != "ok") s << "  " << h.status;
      s << "\n";
    }
    std::snprintf(line, sizeof line, "  %-24s %9s  %8.4f  %8.4f  %+6.3f\n", "all", "", d.rmse_base_heldout_runs,
                  d.rmse_extended_heldout_runs, d.gain_heldout_runs);
    s << line;
  }
  return s.str();
}

std::vector<std::string> write_report(const Diagnosis& d, const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::vector<std::string> files;
  fs::create_directories(dir);
  {
    std::ofstream j(dir / "diagnosis.json");
    j << to_json(d).dump(2) << "\n";
    if (!j) throw std::runtime_error("cannot write " + (dir / "diagnosis.json").string());
    files.push_back((dir / "diagnosis.json").string());
  }
  // Plot data: one file per run (t, measured, base, extended, residual base, residual ext).
  std::ofstream gp(dir / "plots.gp");
  gp << "set terminal pngcairo size 1400,800\nset grid\nset key outside top center horizontal\n";
  const std::string ext_label = d.cause != "none" ? d.cause : (d.best_candidate + " (not significant)");
  for (std::size_t k = 0; k < d.series.size(); ++k) {
    const RunSeries& s = d.series[k];
    const std::string dat = "run" + std::to_string(k + 1) + ".dat";
    std::ofstream f(dir / dat);
    f << "# t measured base extended res_base res_ext\n";
    for (std::size_t i = 0; i < s.t.size() && i < s.base.size(); ++i) {
      const double ext = i < s.extended.size() ? s.extended[i] : NAN;
      f << s.t[i] << ' ' << s.measured[i] << ' ' << s.base[i] << ' ' << ext << ' '
        << s.measured[i] - s.base[i] << ' ' << s.measured[i] - ext << '\n';
    }
    files.push_back((dir / dat).string());
    gp << "set output '" << "run" << k + 1 << ".png'\nset multiplot layout 2,1 title "
       << gp_str(s.name + ": measured vs " + to_string(d.base_model) + " and + " + ext_label) << "\n"
       << "set ylabel 'F_d [N]'\nplot '" << dat << "' u 1:2 w l lc 'gray' t 'measured', '' u 1:3 w l lc 'blue' t 'base', '' u 1:4 w l lc 'red' t 'extended'\n"
       << "set ylabel 'residual [N]'\nset xlabel 't [s]'\nplot '" << dat << "' u 1:5 w l lc 'blue' t 'base', '' u 1:6 w l lc 'red' t 'extended'\n"
       << "unset multiplot\nunset xlabel\n";
  }
  // Evidence: the base's and the extended model's residuals against what each cause acts on.
  auto table = [&](const std::string& name, const std::vector<std::vector<double>>& cols,
                   const char* header) {
    std::ofstream f(dir / name);
    f << "# " << header << "\n";
    const std::size_t n = cols.empty() ? 0 : cols[0].size();
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t c = 0; c < cols.size(); ++c)
        f << (c ? " " : "") << (i < cols[c].size() ? cols[c][i] : NAN);
      f << '\n';
    }
    files.push_back((dir / name).string());
    return n > 0;
  };
  const Evidence& e = d.evidence;
  std::vector<bool> have;
  for (const char* var : {"velocity", "stick_time", "position"}) {
    const ResidualProfile* p = nullptr;
    for (const auto& q : e.profiles)
      if (q.variable == var) p = &q;
    have.push_back(p && table(std::string("profile_") + var + ".dat", {p->center, p->base, p->extended},
                              "center base_residual extended_residual (SI)"));
  }
  have.push_back(table("spectrum_x.dat", {e.x_spectrum.period, e.x_spectrum.base, e.x_spectrum.extended},
                       "wavelength[m] base_amplitude[N] extended_amplitude[N]"));
  have.push_back(table("spectrum_t.dat", {e.t_spectrum.period, e.t_spectrum.base, e.t_spectrum.extended},
                       "period[s] base_amplitude[N] extended_amplitude[N]"));
  have.push_back(table("stage_levels.dat", {e.stage_va, e.stage_mean_residual, e.stage_mean_residual_extended},
                       "va[m/s] base_mean_residual[N] extended_mean_residual[N]"));
  struct Panel {
    const char* file;
    const char* title;
    const char* xlabel;
    const char* using_x;  ///< gnuplot expression of the x column
    bool logx;
    const char* style;
  };
  const Panel panels[] = {
      {"profile_velocity.dat", "residual vs velocity (sliding)", "x' [mm/s]", "($1*1e3)", false, "lp"},
      {"profile_stick_time.dat", "residual vs stick time", "time since sliding [s]", "1", false, "lp"},
      {"profile_position.dat", "residual vs position (trend)", "x [mm]", "($1*1e3)", false, "lp"},
      {"spectrum_x.dat", "residual spectrum vs x", "wavelength [mm]", "($1*1e3)", true, "l"},
      {"spectrum_t.dat", "residual spectrum vs t", "frequency [Hz]", "(1/$1)", true, "l"},
      {"stage_levels.dat", "stage mean residual vs v_a", "v_a [mm/s]", "($1*1e3)", false, "p pt 7"}};
  const int marked = evidence_panel(d.cause);
  gp << "set output 'evidence.png'\nset terminal pngcairo size 1500,900\n"
     << "set multiplot layout 2,3 title "
     << gp_str(std::string("evidence: residuals of ") + to_string(d.base_model) + " (blue) and + " +
               ext_label + " (red); named cause: " + d.cause)
     << "\n";
  for (int i = 0; i < 6; ++i) {
    const Panel& p = panels[i];
    if (!have[i]) {
      gp << "set multiplot next\n";
      continue;
    }
    gp << "set title " << gp_str(std::string(i + 1 == marked ? "[cause] " : "") + p.title) << "\n"
       << "set xlabel " << gp_str(p.xlabel) << "\nset ylabel '"
       << (i == 3 || i == 4 ? "amplitude [N]" : "residual [N]") << "'\n" << (p.logx ? "set logscale x\n" : "unset logscale x\n")
       << "plot '" << p.file << "' u " << p.using_x << ":2 w " << p.style << " lc 'blue' t 'base', '' u "
       << p.using_x << ":3 w " << p.style << " lc 'red' t 'extended'\n";
  }
  gp << "unset multiplot\nunset title\nunset logscale x\n";
  gp.close();
  files.push_back((dir / "plots.gp").string());
  common::GnuplotCall call;
  call.script = "plots.gp";
  call.workdir = dir;
  call.log = dir / "gnuplot.log";
  call.log_stdout = true;
  const int status = common::run_gnuplot(call);
  if (status == 0) {
    for (std::size_t k = 0; k < d.series.size(); ++k)
      files.push_back((dir / ("run" + std::to_string(k + 1) + ".png")).string());
    files.push_back((dir / "evidence.png").string());
  } else if (status == common::kGnuplotNotFound) {
    files.push_back("plots skipped: gnuplot not found (run gnuplot plots.gp in the directory)");
  } else {
    files.push_back("plots failed: see " + (dir / "gnuplot.log").string());
  }
  return files;
}

}  // namespace stickslip::diagnosis
