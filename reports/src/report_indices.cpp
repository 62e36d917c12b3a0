// The nightly report's indices section (report_plot.h): the heat map of every output's main index
// per parameter, then per output its status, warnings, bars with intervals, table ("≈ 0" rule),
// second-order table and the convergence plot of a Sobol study.
#include <cmath>
#include <sstream>

#include "report_plot.h"
#include "stickslip/studies/sa_json.h"

namespace stickslip::reports::detail {
namespace {

using json = nlohmann::json;
namespace sa = studies::sensitivity;

sa::Interval interval_of(const json& ci) {
  const double nan = std::nan("");
  if (!ci.is_array() || ci.size() != 2) return {nan, nan};
  return {ci[0].is_number() ? ci[0].get<double>() : nan, ci[1].is_number() ? ci[1].get<double>() : nan};
}

double number_of(const json& v) { return v.is_number() ? v.get<double>() : std::nan(""); }

/// Parameters x outputs, colour = the method's main index, each cell labelled with its value and
/// interval; undefined / invalid outputs are blank columns that say so.
std::string heatmap_figure(Plotter& plot, const std::string& id, const json& ind) {
  const json& hm = ind.at("heatmap");
  const std::string index = hm.value("index", "");
  Heatmap h;
  for (const json& o : hm.at("outputs")) h.columns.push_back(o.get<std::string>());
  for (const json& p : hm.at("parameters")) h.rows.push_back(p.get<std::string>());
  h.value.assign(h.rows.size(), std::vector<double>(h.columns.size(), std::nan("")));
  h.text.assign(h.rows.size(), std::vector<std::string>(h.columns.size()));
  for (std::size_t c = 0; c < h.columns.size(); ++c) {
    const std::string status = hm["status"][c].get<std::string>();
    for (std::size_t r = 0; r < h.rows.size(); ++r) {
      if (status != "ok") {
        h.text[r][c] = status;
        continue;
      }
      h.value[r][c] = number_of(hm["value"][c][r]);
      const json& ci = hm["ci"][c][r];
      const sa::Interval i = interval_of(ci);
      h.text[r][c] = sa::display_index(h.value[r][c], ci.is_null() ? nullptr : &i, "%.2f");
      if (!ci.is_null()) h.text[r][c] += "\n" + sa::display_interval(i, "%.2f");
    }
  }
  h.xlabel = "output";
  h.cblabel = index;
  h.title = index + " per parameter and output (labels: estimate and interval)";
  h.palette = "defined (0 '#ffffff', 1 '#6baed6', 2 '#08306b')";
  if (index != "mu_star" && index != "nu") {
    h.cbmin = 0.0;
    h.cbmax = 1.0;
  }
  return plot.figure(id + "-heatmap", 140 + 150 * static_cast<int>(h.columns.size()),
                     110 + 42 * static_cast<int>(h.rows.size()), heatmap_script(h),
                     index + " of every parameter (rows) for every output (columns) of " + id +
                         ", with its bootstrap interval; blank columns: outputs without indices "
                         "(undefined or invalid, see below)");
}

/// Bars of every index with an interval, per parameter.
std::string bars_figure(Plotter& plot, const std::string& id, const std::string& out,
                        const json& idx, const std::vector<std::string>& names) {
  std::ostringstream b;
  b << "$d << EOD\n";
  for (const json& x : idx) {
    b << gp_quote(x.value("parameter", ""));
    for (const auto& n : names) b << ' ' << g(x[n]) << ' ' << g(x[n + "_ci"][0]) << ' ' << g(x[n + "_ci"][1]);
    b << '\n';
  }
  b << "EOD\nset style data histogram\nset style histogram errorbars gap 1 lw 1\n"
    << "set style fill solid 0.7 border -1\nset boxwidth 0.9\nset grid ytics\n"
    << "set ylabel 'index [-]'\nset key top right\nset title " << gp_quote("indices of " + out)
    << "\nplot ";
  const char* colours[] = {"#4477aa", "#ee6677", "#228833", "#ccbb44"};
  for (std::size_t k = 0; k < names.size(); ++k)
    b << (k ? ", '' using " : "$d using ") << 2 + 3 * k << ':' << 3 + 3 * k << ':' << 4 + 3 * k
      << (k ? "" : ":xtic(1)") << " title " << gp_quote(names[k]) << " lc rgb '" << colours[k % 4] << "'";
  b << "\n";
  return plot.figure(id + "-bars-" + out, 900, 420, b.str(),
                     "Indices of " + out + " with their bootstrap intervals (" + id + ")");
}

/// Morris: mu* against sigma, horizontal bars the intervals of mu*.
std::string morris_figure(Plotter& plot, const std::string& id, const std::string& out,
                          const json& idx) {
  std::ostringstream b;
  b << "$d << EOD\n";
  for (const json& x : idx)
    b << gp_quote(x.value("parameter", "")) << ' ' << g(x["mu_star"]) << ' '
      << g(x["mu_star_ci"][0]) << ' ' << g(x["mu_star_ci"][1]) << ' ' << g(x["sigma"]) << '\n';
  b << "EOD\nset grid\nset xlabel " << gp_quote("mu* [output unit per parameter range]")
    << "\nset ylabel " << gp_quote("sigma") << "\nset key off\nset offsets 0, graph 0.15, graph "
    << "0.1, 0\nset xrange [0:*]\nset yrange [0:*]\nset title " << gp_quote("Morris screening of " + out)
    << "\nplot $d using 2:5:3:4 with xerrorbars pt 7 lc rgb '#228833', "
       "'' using 2:5:1 with labels offset char 1,char 0.7 left\n";
  return plot.figure(id + "-morris-" + out, 800, 500, b.str(),
                     "Morris mu* against sigma for " + out +
                         " (horizontal bars: bootstrap intervals of mu*) (" + id + ")");
}

/// ST (and S1) against N on the nested prefixes, one line per parameter, with intervals.
std::string convergence_figure(Plotter& plot, const std::string& id, const std::string& out,
                               const json& steps, const std::vector<std::string>& parameters) {
  std::ostringstream b;
  for (std::size_t p = 0; p < parameters.size(); ++p) {
    b << "$p" << p << " << EOD\n";
    for (const json& s : steps) {
      const json& x = s["indices"][p];
      b << s.value("n", 0) << ' ' << g(x["ST"]) << ' ' << g(x["ST_ci"][0]) << ' ' << g(x["ST_ci"][1]) << '\n';
    }
    b << "EOD\n";
  }
  b << "set logscale x 2\nset grid\nset xlabel 'base sample size N'\nset ylabel 'ST [-]'\n"
    << "set key outside right\nset title " << gp_quote("convergence of ST, " + out) << "\nplot ";
  for (std::size_t p = 0; p < parameters.size(); ++p)
    b << (p ? ", " : "") << "$p" << p << " using ($1*" << g(1.0 + 0.02 * static_cast<double>(p))
      << "):2:3:4 with yerrorlines lc " << p + 1 << " pt 7 ps 0.5 title " << gp_quote(parameters[p]);
  b << "\n";
  return plot.figure(id + "-convergence-" + out, 900, 450, b.str(),
                     "Total indices of " + out + " on the nested prefixes N = 16, 32, ... of the "
                     "Sobol design, with their bootstrap intervals (" + id + ")");
}

std::string table(const json& o, const std::vector<std::string>& names) {
  std::ostringstream h;
  h << "<table><tr><th>parameter</th>";
  for (const auto& n : names) h << "<th>" << html_escape(n) << "</th><th>interval</th>";
  h << "</tr>\n";
  for (const json& x : o.value("indices", json::array())) {
    h << "<tr><td>" << html_escape(x.value("parameter", "")) << "</td>";
    for (const auto& n : names) {
      const bool has_ci = x.contains(n + "_ci");
      const sa::Interval i = interval_of(has_ci ? x[n + "_ci"] : json());
      h << "<td>" << html_escape(sa::display_index(number_of(x[n]), has_ci ? &i : nullptr)) << "</td><td>"
        << (has_ci ? html_escape(sa::display_interval(i)) : "") << "</td>";
    }
    h << "</tr>\n";
  }
  h << "</table>\n";
  if (o.contains("second_order")) {
    h << "<table><tr><th>pair</th><th>S2</th><th>interval</th></tr>\n";
    for (const json& x : o["second_order"]) {
      const sa::Interval i = interval_of(x["S2_ci"]);
      h << "<tr><td>" << html_escape(x["parameters"][0].get<std::string>() + ", " +
                                     x["parameters"][1].get<std::string>())
        << "</td><td>" << html_escape(sa::display_index(number_of(x["S2"]), &i)) << "</td><td>"
        << html_escape(sa::display_interval(i)) << "</td></tr>\n";
    }
    h << "</table>\n";
  }
  return h.str();
}

std::string status_html(const json& o) {
  std::ostringstream h;
  const std::string status = o.value("status", "invalid");
  if (status == "undefined") {
    h << "<p class=\"bad\">UNDEFINED: " << html_escape(o.value("reason", "")) << "</p>\n";
  } else if (status != "ok") {
    h << "<p class=\"bad\">INVALID: " << html_escape(o.value("reason", "")) << "</p>\n<ul>";
    for (const json& p : o.value("invalid_points", json::array()))
      h << "<li>design index " << p.value("design_index", -1) << ": "
        << html_escape(p.value("status", "")) << " " << html_escape(p.value("reason", "")) << "</li>";
    h << "</ul>\n";
  }
  for (const json& w : o.value("warnings", json::array()))
    h << "<p class=\"warn\">warning: " << html_escape(w.get<std::string>()) << "</p>\n";
  for (const json& n : o.value("notes", json::array()))
    h << "<p>note: " << html_escape(n.get<std::string>()) << "</p>\n";
  return h.str();
}

/// Index names of an output's entries, in the order of the first parameter's keys that have
/// intervals (bars) or all of them (table).
std::vector<std::string> index_names(const json& idx, bool with_ci_only) {
  std::vector<std::string> names;
  if (idx.empty()) return names;
  for (const auto& item : idx[0].items()) {
    const std::string& key = item.key();
    if (key == "parameter" || key.ends_with("_ci") || key.ends_with("_resamples")) continue;
    if (with_ci_only && !idx[0].contains(key + "_ci")) continue;
    names.push_back(key);
  }
  return names;
}

}  // namespace

std::string indices_section(Plotter& plot, const std::string& id, const json& ind) {
  std::ostringstream h;
  const std::string method = ind.value("method", "");
  h << "<p>" << html_escape(ind.value("design", "")) << " design, method " << html_escape(method)
    << ", N = " << ind.value("n", 0) << ", " << ind.value("stored_runs", 0) << " of "
    << ind.value("total_runs", 0) << " runs stored, " << ind.value("failed_runs", 0) << " failed; "
    << fmt(ind.value("confidence", json(0.95)), "%.2g") << " bootstrap intervals ("
    << ind.value("resamples", 0) << " resamples). An estimate below 0 whose interval covers 0 "
    << "is shown as &asymp; 0.</p>\n";
  if (const auto raised = ind.value("F_S_raised_runs", 0); raised > 0)
    h << "<p>" << raised << " runs had F_S &lt; F_C and were simulated with F_S = F_C "
      << "(the study's F_S_below_F_C policy).</p>\n";
  if (ind.contains("until"))
    h << "<p>Run until the widest ST interval is &le; " << fmt(ind["until"]["max_st_width"], "%.3g")
      << " (N at most " << ind["until"].value("n_max", 0) << "): "
      << html_escape(ind["until"].value("reason", "")) << ".</p>\n";
  const std::vector<std::string> parameters = ind.value("parameters", std::vector<std::string>{});
  h << heatmap_figure(plot, id, ind);
  for (const json& o : ind.value("outputs", json::array())) {
    const std::string out = o.value("output", "");
    h << "<h4>" << html_escape(out) << "</h4>\n" << status_html(o);
    if (o.value("status", "") != "ok") continue;
    const json idx = o.value("indices", json::array());
    h << (method == "morris" ? morris_figure(plot, id, out, idx)
                             : bars_figure(plot, id, out, idx, index_names(idx, true)));
    h << table(o, index_names(idx, false));
    if (o.contains("convergence"))
      h << convergence_figure(plot, id, out, o["convergence"], parameters);
  }
  return h.str();
}

}  // namespace stickslip::reports::detail
