// diagnosis.json, the stdout summary and the gnuplot plots of a Diagnosis.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "stickslip/studies/json_number.h"
#include "stickslip/studies/diagnose.h"

namespace stickslip::studies {
namespace {


nlohmann::json params_json(const std::vector<ParamEstimate>& ps) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& p : ps) j[p.name] = {{"value", json_number(p.value)}, {"stderr", json_number(p.stderr_)}};
  return j;
}

nlohmann::json stages_json(const std::vector<StageScore>& ss, const Diagnosis& d) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& s : ss)
    a.push_back({{"run", d.run_names.at(s.run)},
                 {"stage", s.stage + 1},
                 {"amplitude", {{"measured", json_number(s.measured_amplitude)}, {"model", json_number(s.model_amplitude)}}},
                 {"mean_force", {{"measured", json_number(s.measured_mean)}, {"model", json_number(s.model_mean)}}},
                 {"mean_period", {{"measured", json_number(s.measured_period)}, {"model", json_number(s.model_period)}}},
                 {"slip_events", {{"measured", s.measured_slips}, {"model", s.model_slips}}}});
  return a;
}

}  // namespace

nlohmann::json to_json(const Diagnosis& d) {
  nlohmann::json j;
  j["dataset"] = d.dataset;
  j["base_model"] = to_string(d.base_model);
  j["base_params"] = params_json(d.base_params);
  j["cause"] = d.cause;
  j["best_candidate"] = d.best_candidate;
  j["rmse_base_heldout"] = json_number(d.rmse_base_heldout);
  j["rmse_extended_heldout"] = json_number(d.rmse_extended_heldout);
  j["gain"] = json_number(d.gain);
  auto& cands = j["candidates"] = nlohmann::json::array();
  for (const auto& c : d.candidates)
    cands.push_back({{"id", to_string(c.kind)},
                     {"status", c.status},
                     {"params", params_json(c.params)},
                     {"base_params", params_json(c.base_params)},
                     {"offset", json_number(c.offset)},
                     {"rmse_fit", json_number(c.rmse_fit)},
                     {"rmse_heldout", json_number(c.rmse_heldout)},
                     {"gain", json_number(c.gain)},
                     {"aic", json_number(c.aic)},
                     {"lr", json_number(c.lr)},
                     {"dof", c.dof},
                     {"p_value", json_number(c.p_value)},
                     {"p_holm", json_number(c.p_holm)},
                     {"significant", c.significant},
                     {"at_base_point", c.at_base_point},
                     {"evaluations", c.evals}});
  const Evidence& e = d.evidence;
  nlohmann::json lv = nlohmann::json::array();
  for (std::size_t i = 0; i < e.stage_mean_residual.size(); ++i)
    lv.push_back({{"va", json_number(e.stage_va[i])}, {"mean_residual", json_number(e.stage_mean_residual[i])}});
  j["evidence"] = {{"residual_rms", json_number(e.residual_rms)},
                   {"lag1_autocorrelation", json_number(e.rho)},
                   {"n_fit", json_number(e.n)},
                   {"n_effective", json_number(e.n_eff)},
                   {"corr_velocity", json_number(e.corr_velocity)},
                   {"corr_position", json_number(e.corr_position)},
                   {"corr_stick_time", json_number(e.corr_stick_time)},
                   {"trend_per_m", json_number(e.trend_per_m)},
                   {"x_spectrum_peak", {{"wavelength", json_number(e.wavelength)},
                                        {"amplitude", json_number(e.wavelength_amplitude)},
                                        {"phase", json_number(e.wavelength_phase)},
                                        {"power_over_median", json_number(e.wavelength_ratio)}}},
                   {"stage_level_vs_va", lv},
                   {"per_stage", stages_json(e.stages, d)}};
  auto& cal = j["calibrations"] = nlohmann::json::array();
  for (const auto& c : d.calibrations) {
    nlohmann::json runs = nlohmann::json::object();
    for (std::size_t k = 0; k < c.rmse_run.size(); ++k) runs[d.run_names[k]] = json_number(c.rmse_run[k]);
    cal.push_back({{"model", to_string(c.model)},
                   {"status", c.status},
                   {"params", params_json(c.params)},
                   {"offset", json_number(c.offset)},
                   {"rmse_fit", json_number(c.rmse_fit)},
                   {"rmse_heldout", json_number(c.rmse_heldout)},
                   {"rmse_run", runs},
                   {"aic", json_number(c.aic)},
                   {"evaluations", c.evals},
                   {"per_stage", stages_json(c.stages, d)}});
  }
  const auto& o = d.options;
  j["method"] = {{"fit_rate", o.fit_rate},
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
    gp << "set output '" << "run" << k + 1 << ".png'\nset multiplot layout 2,1 title '" << s.name
       << ": measured vs " << to_string(d.base_model) << " and + " << ext_label << "'\n"
       << "set ylabel 'F_d [N]'\nplot '" << dat << "' u 1:2 w l lc 'gray' t 'measured', '' u 1:3 w l lc 'blue' t 'base', '' u 1:4 w l lc 'red' t 'extended'\n"
       << "set ylabel 'residual [N]'\nset xlabel 't [s]'\nplot '" << dat << "' u 1:5 w l lc 'blue' t 'base', '' u 1:6 w l lc 'red' t 'extended'\n"
       << "unset multiplot\nunset xlabel\n";
  }
  gp.close();
  files.push_back((dir / "plots.gp").string());
  if (std::system("command -v gnuplot >/dev/null 2>&1") == 0) {
    const std::string cmd = "cd '" + dir.string() + "' && gnuplot plots.gp > gnuplot.log 2>&1";
    if (std::system(cmd.c_str()) == 0) {
      for (std::size_t k = 0; k < d.series.size(); ++k)
        files.push_back((dir / ("run" + std::to_string(k + 1) + ".png")).string());
    } else {
      files.push_back("plots failed: see " + (dir / "gnuplot.log").string());
    }
  } else {
    files.push_back("plots skipped: gnuplot not found (run gnuplot plots.gp in the directory)");
  }
  return files;
}

}  // namespace stickslip::studies
