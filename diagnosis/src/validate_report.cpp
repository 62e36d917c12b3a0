// validation.json, the CSV per run, the summary and the plots of a Validation (validate.h).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "stickslip/common/gnuplot.h"
#include "stickslip/common/json_number.h"
#include "stickslip/diagnosis/validate.h"

namespace stickslip::diagnosis {

namespace {

using common::json_number;

nlohmann::json stage_json(const StagePrediction& p) {
  return {{"stage", p.stage + 1},
          {"measured", stats_to_json(p.measured)},
          {"base", stats_to_json(p.base)},
          {"extended", stats_to_json(p.extended)},
          {"score_base", json_number(p.score_base)},
          {"score_extended", json_number(p.score_extended)},
          {"mean_error", json_number(p.mean_error)},
          {"drop_error", json_number(p.drop_error)},
          {"rate_error", json_number(p.rate_error)},
          {"reproduced", p.reproduced}};
}

/// A file name from a run name: characters other than letters, digits, '-', '_' and '.' become
/// '_' (a run name may hold anything a manifest allows).
std::string file_stem(const std::string& run) {
  std::string s = run.empty() ? std::string("run") : run;
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) c = '_';
  if (s.front() == '.') s.front() = '_';
  return s;
}

std::string gp_str(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

/// The gnuplot script of one run's plot: the whole record (every n-th sample, at most ~20000
/// points) and its first periods.
std::string plot_script(const RunValidation& r, const Validation& v, const std::string& stem) {
  const std::size_t every = std::max<std::size_t>(1, r.t.size() / 20000);
  double zoom = r.t.empty() ? 1.0 : r.t.back();
  if (!r.stages.empty() && r.stages.front().measured.interval_median > 0)
    zoom = std::min(zoom, 8 * r.stages.front().measured.interval_median);
  else
    zoom = std::min(zoom, 20 * 2 * M_PI * std::sqrt(r.conditions.m / r.conditions.kd));
  const std::string ext = v.cause != "none" ? "+ " + v.cause : "(no cause named)";
  std::ostringstream g;
  g << "set terminal pngcairo size 1400,900\nset output " << gp_str(stem + ".png") << "\nset grid\n"
    << "set datafile separator ','\nset key outside top center horizontal\n"
    // One script plots every run: the previous run's zoom and labels must not carry over.
    << "unset xlabel\nset autoscale x\n"
    << "set multiplot layout 2,1 title " << gp_str(r.run + ": measured vs " + engine::to_string(v.base.model) +
                                                    " and " + ext + " (calibrated on " + v.diagnosis_dataset + ")")
    << " noenhanced\nset ylabel 'F_d [N]'\n"  // the title's names hold underscores
    << "plot " << gp_str(stem + ".csv") << " every " << every << "::1 u 1:2 w l lc 'gray' t 'measured', '' every "
    << every << "::1 u 1:3 w l lc 'blue' t 'base', '' every " << every << "::1 u 1:4 w l lc 'red' t 'extended'\n"
    << "set xlabel 't [s]'\nset xrange [0:" << zoom << "]\n"
    << "plot " << gp_str(stem + ".csv") << " u 1:2 w l lc 'gray' t 'measured', '' u 1:3 w l lc 'blue' t 'base', "
    << "'' u 1:4 w l lc 'red' t 'extended'\nunset multiplot\n";
  return g.str();
}

}  // namespace

nlohmann::json to_json(const Validation& v) {
  nlohmann::json runs = nlohmann::json::array();
  for (const auto& r : v.runs) {
    nlohmann::json stages = nlohmann::json::array();
    for (const auto& p : r.stages) stages.push_back(stage_json(p));
    const std::string stem = file_stem(r.run);
    runs.push_back({{"run", r.run},
                    {"status", r.status},
                    {"conditions", {{"m", r.conditions.m}, {"kd", r.conditions.kd}, {"vd", r.conditions.vd},
                                    {"f", r.conditions.f}, {"va", r.conditions.va}, {"t_on", r.conditions.t_on},
                                    {"duration", r.conditions.duration}}},
                    {"reading", reading_to_json(r.reading)},
                    {"stages", stages},
                    {"rmse_base", json_number(r.rmse_base)},
                    {"rmse_extended", json_number(r.rmse_extended)},
                    {"csv", stem + ".csv"},
                    {"plot", stem + ".png"}});
  }
  return {{"diagnosis_dataset", v.diagnosis_dataset},
          {"dataset", v.dataset},
          {"cause", v.cause},
          {"verdict", v.verdict},
          {"models", {{"base", calibrated_json(v.base)}, {"extended", calibrated_json(v.extended)}}},
          {"runs", runs},
          {"seconds", v.seconds}};
}

std::string validation_csv(const RunValidation& r) {
  std::string out = "t,Fd_measured,Fd_base,Fd_extended\n";
  out.reserve(r.t.size() * 48 + 40);
  char line[128];
  for (std::size_t i = 0; i < r.t.size(); ++i) {
    const double b = i < r.base.size() ? r.base[i] : NAN, e = i < r.extended.size() ? r.extended[i] : NAN;
    std::snprintf(line, sizeof line, "%.9g,%.9g,%.9g,%.9g\n", r.t[i], r.measured[i], b, e);
    out += line;
  }
  return out;
}

std::string summary_text(const Validation& v) {
  std::ostringstream s;
  char line[512];
  s << "validation of the models calibrated on " << v.diagnosis_dataset << " (" << engine::to_string(v.base.model)
    << ", cause " << v.cause << ", verdict " << v.verdict << ") on " << v.dataset << ":\n"
    << "  run              stage regime (measured/base/ext)        mean [N] meas/ext    drop [N] meas/ext    drops/s meas/ext  score base/ext  RMSE base/ext [N]\n";
  for (const auto& r : v.runs) {
    if (r.status != "ok") {
      s << "  " << r.run << ": " << r.status << "\n";
      continue;
    }
    for (const auto& p : r.stages) {
      std::snprintf(line, sizeof line,
                    "  %-16s %3d  %-10s %-10s %-10s  %7.4g %7.4g  %7.3g %7.3g  %7.3g %7.3g  %6.2f %6.2f  %7.4f %7.4f  %s\n",
                    r.run.c_str(), p.stage + 1, to_string(p.measured.regime), to_string(p.base.regime),
                    to_string(p.extended.regime), p.measured.mean, p.extended.mean, p.measured.drop_median,
                    p.extended.drop_median, p.measured.rate, p.extended.rate, p.score_base, p.score_extended,
                    r.rmse_base, r.rmse_extended, p.reproduced ? "reproduced" : "not reproduced");
      s << line;
    }
  }
  return s.str();
}

std::vector<std::string> write_validation(const Validation& v, const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::vector<std::string> files;
  fs::create_directories(dir);
  {
    std::ofstream j(dir / "validation.json");
    j << to_json(v).dump(2) << "\n";
    if (!j) throw std::runtime_error("cannot write " + (dir / "validation.json").string());
    files.push_back((dir / "validation.json").string());
  }
  std::ofstream gp(dir / "plots.gp");
  for (const auto& r : v.runs) {
    const std::string stem = file_stem(r.run);
    std::ofstream f(dir / (stem + ".csv"));
    f << validation_csv(r);
    if (!f) throw std::runtime_error("cannot write " + (dir / (stem + ".csv")).string());
    files.push_back((dir / (stem + ".csv")).string());
    if (r.status == "ok") gp << plot_script(r, v, stem);
  }
  gp.close();
  common::GnuplotCall call;
  call.script = "plots.gp";
  call.workdir = dir;
  call.log = dir / "gnuplot.log";
  call.log_stdout = true;
  const int status = common::run_gnuplot(call);
  if (status == 0) {
    for (const auto& r : v.runs)
      if (r.status == "ok") files.push_back((dir / (file_stem(r.run) + ".png")).string());
  } else if (status == common::kGnuplotNotFound) {
    files.push_back("plots skipped: gnuplot not found (run gnuplot plots.gp in the directory)");
  } else {
    files.push_back("plots failed: see " + (dir / "gnuplot.log").string());
  }
  return files;
}

}  // namespace stickslip::diagnosis
