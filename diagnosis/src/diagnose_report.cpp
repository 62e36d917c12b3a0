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

namespace {

/// "readings" and the adequacy verdict.
void summary_readings(const Diagnosis& d, std::ostringstream& s) {
  char line[512];
  s << "scoring: " << d.scoring << "\n";
  for (const auto& r : d.readings) {
    std::snprintf(line, sizeof line,
                  "  %-16s noise %.3g N (rho %.2f), %zu spikes (%.2f %%), preload %.4g N (%s, %s), "
                  "burn-in %.3g s: %s\n",
                  r.run.c_str(), r.noise_sigma, r.noise_rho, r.spikes, 100 * r.spike_fraction, r.preload,
                  r.from_rest ? "from rest" : "mid-experiment", r.stuck_at_start ? "stuck" : "sliding",
                  r.burn_in, r.why.c_str());
    s << line;
    if (!r.defaulted.empty())
      s << "  " << std::string(16, ' ') << " not in the manifest, the seed's values taken: "
        << r.defaulted_text << "\n";
  }
}

void summary_adequacy(const Diagnosis& d, std::ostringstream& s) {
  char line[512];
  const Adequacy& a = d.adequacy;
  std::snprintf(line, sizeof line,
                "verdict: %s (noise floor %.3g N; held-out RMSE base %.4g N vs a constant %.4g N; "
                "statistics score base %.3g vs no stick-slip %.3g)\n",
                a.verdict.c_str(), a.noise_floor, a.rmse_base_heldout, a.rmse_constant_heldout,
                a.score_base_heldout, a.score_constant_heldout);
  s << line;
  for (const auto& m : a.missing) s << "  missing: " << m << "\n";
  if (a.extended_verdict == "adequate")
    s << "  the named cause's extended model is adequate: the record is reproduced with the effect\n";
  else if (a.extended_verdict == "inadequate")
    s << "  no candidate both passes the tests and makes the model adequate: no cause is named\n";
  s << "statistics (measured / base / extended; fitted parts):\n"
    << "  run              regime                          mean [N]               median drop [N]          drops/s\n";
  for (const auto& c : d.statistics) {
    if (c.held) continue;
    std::snprintf(line, sizeof line, "  %-16s %-10s %-10s %-10s %7.4g %7.4g %7.4g   %7.3g %7.3g %7.3g   %6.3g %6.3g %6.3g\n",
                  c.run.c_str(), to_string(c.measured.regime), to_string(c.base.regime),
                  to_string(c.extended.regime), c.measured.mean, c.base.mean, c.extended.mean,
                  c.measured.drop_median, c.base.drop_median, c.extended.drop_median, c.measured.rate,
                  c.base.rate, c.extended.rate);
    s << line;
  }
}

void summary_calibrations(const Diagnosis& d, std::ostringstream& s) {
  char line[256];
  const bool stats = d.scoring == "statistics";
  s << (stats ? "calibration (statistics score [-], 1 = off by the tolerance; held-out = last part of every stage):\n"
              : "calibration (RMSE [N]; held-out = last part of every stage):\n");
  s << "  model             held-out    fit   per run\n";
  for (const auto& c : d.calibrations) {
    std::snprintf(line, sizeof line, "  %-16s %8.4f %8.4f  ", to_string(c.model),
                  stats ? c.score_heldout : c.rmse_heldout, stats ? c.score_fit : c.rmse_fit);
    s << line;
    for (double r : c.rmse_run) {
      std::snprintf(line, sizeof line, " %.4f", r);
      s << line;
    }
    if (c.status != "ok") s << "  " << c.status;
    s << "\n";
    for (const auto& p : c.identifiability)
      if (p.status == "held" && !p.why.empty() && p.why.rfind("not fitted", 0) != 0)
        s << "    " << p.name << " held at " << p.value << ": " << p.why << "\n";
  }
  s << "best base model: " << to_string(d.base_model) << " (";
  for (std::size_t i = 0; i < d.base_params.size(); ++i) {
    std::snprintf(line, sizeof line, "%s%s = %.4g +- %.2g", i ? ", " : "", d.base_params[i].name.c_str(),
                  d.base_params[i].value, d.base_params[i].stderr_);
    s << line;
  }
  s << ")\n";
  if (!d.base_note.empty()) s << "  " << d.base_note << "\n";
}

void summary_candidates(const Diagnosis& d, std::ostringstream& s) {
  char line[256];
  const bool stats = d.scoring == "statistics";
  s << (stats ? "candidates (held-out score, gain, Holm p):\n"
              : "candidates (held-out RMSE, gain, gain over the noise, Holm p, size in standard errors):\n");
  for (const auto& c : d.candidates) {
    if (stats)
      std::snprintf(line, sizeof line, "  %-24s %8.4f %+7.3f  p=%.2g%s", to_string(c.kind), c.score_heldout, c.gain,
                    c.p_holm, c.significant ? "  significant" : "");
    else
      std::snprintf(line, sizeof line, "  %-24s %8.4f %+7.3f %+7.3f  p=%.2g  z=%.3g%s", to_string(c.kind),
                    c.rmse_heldout, c.gain, c.gain_over_noise, c.p_holm, c.size_z, c.significant ? "  significant" : "");
    s << line;
    if (!c.params.empty()) {
      std::snprintf(line, sizeof line, "  %s = %.4g +- %.2g", c.params[0].name.c_str(), c.params[0].value, c.params[0].stderr_);
      s << line;
    }
    if (c.status != "ok") s << "  " << c.status;
    if (!c.adequacy.empty()) s << "  extended model " << c.adequacy;
    s << "\n";
  }
  std::snprintf(line, sizeof line, "cause: %s  (held-out %s %.4f -> %.4f, gain %.3f)\n", d.cause.c_str(),
                stats ? "score" : "RMSE [N]", d.rmse_base_heldout, d.rmse_extended_heldout, d.gain);
  s << line;
}

void summary_holdouts(const Diagnosis& d, std::ostringstream& s) {
  if (d.run_holdouts.empty()) return;
  char line[256];
  const bool stats = d.scoring == "statistics";
  s << "whole runs held out (refitted on the other runs; " << (stats ? "statistics score" : "RMSE [N]")
    << " of the run left out; the extended model's mean, median drop and drop rate against the run's):\n"
    << "  run                      v_a [m/s]      base  extended    gain    mean    drop    rate\n";
  for (const auto& h : d.run_holdouts) {
    std::snprintf(line, sizeof line, "  %-24s %9.3g  %8.4f  %8.4f  %+6.3f  %+5.0f%%  %+5.0f%%  %+5.0f%%  %s", h.run.c_str(), h.va,
                  stats ? h.score_base : h.rmse_base, stats ? h.score_extended : h.rmse_extended, h.gain,
                  100 * h.mean_error, 100 * h.drop_error, 100 * h.rate_error,
                  h.reproduced ? "reproduced" : "not reproduced");
    s << line;
    if (h.status != "ok") s << "  " << h.status;
    s << "\n";
  }
  std::snprintf(line, sizeof line, "  %-24s %9s  %8.4f  %8.4f  %+6.3f\n", "all", "",
                stats ? d.score_base_heldout_runs : d.rmse_base_heldout_runs,
                stats ? d.score_extended_heldout_runs : d.rmse_extended_heldout_runs, d.gain_heldout_runs);
  s << line;
}

}  // namespace

std::string summary_text(const Diagnosis& d) {
  std::ostringstream s;
  char line[256];
  s << "dataset " << d.dataset << ": " << d.run_names.size() << " run(s), diagnosed in ";
  std::snprintf(line, sizeof line, "%.1f s (%d model evaluations)\n", d.seconds, d.evaluations);
  s << line;
  summary_readings(d, s);
  summary_calibrations(d, s);
  summary_adequacy(d, s);
  summary_candidates(d, s);
  summary_holdouts(d, s);
  return s.str();
}

namespace {

/// What the plots call the extended model: the named cause; else the best candidate, marked not
/// significant; else (no candidate tested, e.g. an inadequate base) that there is none.
std::string extension_label(const Diagnosis& d) {
  if (d.cause != "none") return d.cause;
  if (!d.best_candidate.empty() && d.best_candidate != "none")
    return d.best_candidate + " (not significant)";
  return d.adequacy.verdict == "inadequate" ? "no extension: the base is inadequate"
                                            : "no extension";
}

/// Plot data of every run (t, measured, base, extended, residuals) and its panel in the script.
void run_plots(const Diagnosis& d, const std::filesystem::path& dir, std::ostream& gp,
               std::vector<std::string>& files) {
  // Plot data: one file per run (t, measured, base, extended, residual base, residual ext).
  const std::string ext_label = extension_label(d);
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
       << gp_str(s.name + ": measured vs " + to_string(d.base_model) + " and " + ext_label)
       << " noenhanced\n"  // names hold underscores, not subscripts
       << "set ylabel 'F_d [N]'\nplot '" << dat << "' u 1:2 w l lc 'gray' t 'measured', '' u 1:3 w l lc 'blue' t 'base', '' u 1:4 w l lc 'red' t 'extended'\n"
       << "set ylabel 'residual [N]'\nset xlabel 't [s]'\nplot '" << dat << "' u 1:5 w l lc 'blue' t 'base', '' u 1:6 w l lc 'red' t 'extended'\n"
       << "unset multiplot\nunset xlabel\n";
  }
}

/// The evidence tables and evidence.png's six panels, the named cause's marked.
void evidence_plots(const Diagnosis& d, const std::filesystem::path& dir, std::ostream& gp,
                    std::vector<std::string>& files) {
  const std::string ext_label = extension_label(d);
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
     << " noenhanced\n";
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
}

}  // namespace

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
  std::ofstream gp(dir / "plots.gp");
  gp << "set terminal pngcairo size 1400,800\nset grid\nset key outside top center horizontal\n";
  run_plots(d, dir, gp, files);
  evidence_plots(d, dir, gp, files);
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
