// The nightly report's HTML and its gnuplot plots (see report.h).
//
// Plots are drawn by gnuplot (Debian's gnuplot-nox, svg terminal); this file only writes gnuplot
// scripts with the data inline ($data << EOD blocks) and the HTML around them. Each SVG is kept in
// dir/plots/ and embedded in index.html as a base64 data: URI, so the page opens offline and the
// plots' ids cannot clash (inline SVGs from gnuplot reuse the same element ids).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "report_plot.h"
#include "stickslip/reports/report.h"

namespace stickslip::reports {
namespace {

using namespace detail;

namespace fs = std::filesystem;
using json = nlohmann::json;

// ------------------------------------------------------------------------------ maps

std::string first_key_name(const json& map) {
  const json names = map.value("key_names", json::array());
  return names.empty() ? std::string() : names[0].get<std::string>();
}

std::string map_section(Plotter& plot, const std::string& id, const json& map) {
  std::ostringstream h;
  const json models = map.value("models", json::array());
  const json rows = map.value("rows", json::array());
  const std::size_t stages = map.value("stages", 0);
  const std::string xname = first_key_name(map);
  const bool one_key = map.value("key_names", json::array()).size() == 1;
  const std::string xlabel = one_key ? xname : "map row";
  auto xval = [&](std::size_t r) -> std::string {
    return one_key ? g(rows[r]["key"][xname]) : std::to_string(r);
  };
  // Heatmap per stage: x = map row (labelled with the map variable), y = model, colour =
  // amplitude [N]; discrete cells (report_plot.h): the models are categories.
  for (std::size_t s = 0; s < stages; ++s) {
    Heatmap hm;
    for (std::size_t r = 0; r < rows.size(); ++r)
      hm.columns.push_back(one_key ? fmt(rows[r]["key"][xname], "%.3g") : std::to_string(r));
    for (const json& m : models) hm.rows.push_back(m.get<std::string>());
    hm.value.assign(models.size(), std::vector<double>(rows.size(), std::nan("")));
    for (std::size_t m = 0; m < models.size(); ++m)
      for (std::size_t r = 0; r < rows.size(); ++r) {
        const json& cells = rows[r]["cells"];
        const std::string model = models[m];
        if (!cells.contains(model) || cells[model].value("state", "") != "ok") continue;
        const json& amp = cells[model]["amplitude"];
        if (amp.is_array() && s < amp.size() && amp[s].is_number()) hm.value[m][r] = amp[s].get<double>();
      }
    hm.column_tic_every = std::max<std::size_t>(1, rows.size() / 10);
    hm.xlabel = xlabel;
    hm.cblabel = "amplitude [N]";
    hm.title = "stick-slip amplitude, stage " + std::to_string(s + 1);
    const std::string b = heatmap_script(hm);
    h << plot.figure(id + "-heatmap-stage" + std::to_string(s + 1), 820,
                     80 + 60 * static_cast<int>(models.size()) + 80, b,
                     "Stick-slip map (" + id + "), stage " + std::to_string(s + 1) +
                         ": amplitude of F_d [N] per model against " + xlabel +
                         " (blank = failed or missing run)");
  }
  // Amplitude curves: one colour per model, stage 1 dashed, last stage solid.
  std::ostringstream b;
  for (std::size_t m = 0; m < models.size(); ++m) {
    b << "$m" << m << " << EOD\n";
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const json cells = rows[r]["cells"];
      const std::string model = models[m];
      b << xval(r);
      for (std::size_t s = 0; s < stages; ++s) {
        const bool ok = cells.contains(model) && cells[model].value("state", "") == "ok" &&
                        cells[model]["amplitude"].is_array() && s < cells[model]["amplitude"].size();
        b << ' ' << (ok ? g(cells[model]["amplitude"][s]) : "NaN");
      }
      b << '\n';
    }
    b << "EOD\n";
  }
  b << "set xlabel " << gp_quote(xlabel) << "\nset ylabel " << gp_quote("amplitude of F_d [N]")
    << "\nset key outside right\nset grid\nplot ";
  bool first = true;
  for (std::size_t m = 0; m < models.size(); ++m)
    for (std::size_t s = 0; s < stages; ++s) {
      if (stages > 1 && s != 0 && s != stages - 1) continue;
      b << (first ? "" : ", ") << "$m" << m << " using 1:" << s + 2 << " with linespoints lc "
        << m + 1 << " pt 7 ps 0.4 dt " << (s + 1 == stages ? 1 : 2) << " title "
        << gp_quote(models[m].get<std::string>() + ", stage " + std::to_string(s + 1));
      first = false;
    }
  b << "\n";
  h << plot.figure(id + "-curves", 900, 450, b.str(),
                   "Amplitude against " + xlabel + " per model (" + id +
                       "); dashed: stage 1 (still base), solid: last stage");
  return h.str();
}

// ------------------------------------------------------------------------------ traces

// Min/max envelope of F_d per time bin (keeps the stick-slip saw-tooth with few points).
std::vector<std::pair<double, double>> envelope(const std::vector<store::TracePoint>& t, std::size_t bins) {
  std::vector<std::pair<double, double>> out;
  if (t.empty()) return out;
  const std::size_t per = std::max<std::size_t>(1, t.size() / bins);
  for (std::size_t i = 0; i < t.size(); i += per) {
    const std::size_t e = std::min(t.size(), i + per);
    std::size_t lo = i, hi = i;
    for (std::size_t k = i; k < e; ++k) {
      if (t[k].F_d < t[lo].F_d) lo = k;
      if (t[k].F_d > t[hi].F_d) hi = k;
    }
    const std::size_t a = std::min(lo, hi), b = std::max(lo, hi);
    out.emplace_back(t[a].t, t[a].F_d);
    if (b != a) out.emplace_back(t[b].t, t[b].F_d);
  }
  return out;
}

std::string traces_section(Plotter& plot, store::Store& store, const std::string& id, const json& entry) {
  // Group the runs by their conditions without the model: one figure per condition (the seed's
  // Figs. 6-9), one panel per model (a-d).
  std::map<std::string, std::vector<json>> figures;
  std::vector<std::string> order;
  for (const json& t : entry.value("traces", json::array())) {
    json cond = t["point"];
    cond.erase("model");
    const std::string key = cond.dump();
    if (!figures.count(key)) order.push_back(key);
    figures[key].push_back(t);
  }
  std::ostringstream h;
  const std::string study = entry.value("study_id", "");
  int fig = 0;
  for (const std::string& key : order) {
    const auto& runs = figures[key];
    const json cond = json::parse(key);
    std::string cond_text;
    for (const auto& [k, v] : cond.items())
      cond_text += (cond_text.empty() ? "" : ", ") + k + " = " + (v.is_number() ? g(v) : v.dump());
    const std::size_t n = runs.size();
    const std::size_t cols = n > 1 ? 2 : 1, rows_n = (n + cols - 1) / cols;
    std::ostringstream b;
    b << "set multiplot layout " << rows_n << "," << cols << " title "
      << gp_quote("F_d(t): " + cond_text) << "\nset grid\nset xlabel 't [s]'\nset ylabel "
      << gp_quote("F_d [N]") << "\n";
    for (std::size_t i = 0; i < n; ++i) {
      const std::string model = runs[i]["point"].value("model", "?");
      const auto trace = store.get_trace(study, runs[i]["design_index"].get<std::int64_t>());
      b << "set title " << gp_quote(std::string(1, static_cast<char>('a' + i)) + ") " + model)
        << "\n";
      if (!trace || trace->empty()) {
        b << "set label 1 'no trace stored (run failed?)' at graph 0.5,0.5 center\n"
          << "plot [0:1] [0:1] NaN notitle\nunset label 1\n";
        continue;
      }
      b << "$t" << i << " << EOD\n";
      for (const auto& [t, f] : envelope(*trace, 1500)) b << g(t) << ' ' << g(f) << '\n';
      b << "EOD\nplot $t" << i << " using 1:2 with lines lc rgb '#1f4e99' notitle\n";
    }
    b << "unset multiplot\n";
    h << plot.figure(id + "-traces-" + std::to_string(++fig), 1000, 300 * rows_n + 60, b.str(),
                     "Drive force F_d against time for each friction model (" + id + "), " +
                         cond_text + " (style of the seed's Figs. 6-9)");
  }
  return h.str();
}

// ------------------------------------------------------------------------------ changes

std::string key_text(const json& key) {
  std::string s;
  for (const auto& [k, v] : key.items()) s += (s.empty() ? "" : ", ") + k + " = " + g(v);
  return s;
}

std::string changes_section(const json& ch) {
  std::ostringstream h;
  h << "<section id=\"changes\"><h2>Changed since last night</h2>\n";
  if (ch["previous_date"].is_null()) {
    h << "<p>No earlier report in this directory: nothing to compare with.</p></section>\n";
    return h.str();
  }
  const json tol = ch.value("map_tolerance", json::object());
  h << "<p>Compared with the report of " << html_escape(ch["previous_date"].get<std::string>())
    << ". An index is flagged when its confidence interval and the previous one do not overlap; a "
       "map cell when the amplitude of a stage moved by more than "
    << fmt(tol.value("abs", json(0)), "%.3g") << " N + " << fmt(tol.value("rel", json(0)), "%.3g")
    << " &times; |previous amplitude|, or its state changed. <strong class=\""
    << (ch.value("flagged", 0) ? "bad" : "good") << "\">" << ch.value("flagged", 0)
    << " change(s) flagged.</strong></p>\n";
  if (!ch["indices"].empty()) {
    h << "<h3>Indices</h3><table><tr><th>entry</th><th>output</th><th>parameter</th><th>index</th>"
         "<th>previous</th><th>current</th><th>why</th></tr>\n";
    for (const json& f : ch["indices"]) {
      auto val = [&](const char* v, const char* ci) {
        std::string s = f[v].is_boolean() ? (f[v].get<bool>() ? "valid" : "invalid") : fmt(f[v], "%.3f");
        if (f.contains(ci)) s += " [" + fmt(f[ci][0], "%.3f") + ", " + fmt(f[ci][1], "%.3f") + "]";
        return s;
      };
      h << "<tr><td>" << html_escape(f.value("entry", "")) << "</td><td>"
        << html_escape(f.value("output", "")) << "</td><td>"
        << html_escape(f["parameter"].is_string() ? f["parameter"].get<std::string>() : "") << "</td><td>"
        << html_escape(f.value("index", "")) << "</td><td>" << val("previous", "previous_ci")
        << "</td><td>" << val("current", "current_ci") << "</td><td>"
        << html_escape(f.value("reason", "")) << "</td></tr>\n";
    }
    h << "</table>\n";
  }
  if (!ch["map_cells"].empty()) {
    h << "<h3>Map cells</h3><table><tr><th>entry</th><th>model</th><th>cell</th><th>stage</th>"
         "<th>previous [N]</th><th>current [N]</th><th>change [N]</th><th>why</th></tr>\n";
    for (const json& f : ch["map_cells"])
      h << "<tr><td>" << html_escape(f.value("entry", "")) << "</td><td>"
        << html_escape(f.value("model", "")) << "</td><td>" << html_escape(key_text(f["key"]))
        << "</td><td>" << (f.contains("stage") ? std::to_string(f["stage"].get<int>()) : "")
        << "</td><td>" << (f.contains("previous") ? fmt(f["previous"]) : "") << "</td><td>"
        << (f.contains("current") ? fmt(f["current"]) : "") << "</td><td>"
        << (f.contains("delta") ? fmt(f["delta"], "%+.3g") : "") << "</td><td>"
        << html_escape(f.value("reason", "")) << "</td></tr>\n";
    h << "</table>\n";
  }
  if (!ch["notes"].empty()) {
    h << "<h3>Notes</h3><ul>";
    for (const json& n : ch["notes"]) h << "<li>" << html_escape(n.get<std::string>()) << "</li>";
    h << "</ul>\n";
  }
  h << "</section>\n";
  return h.str();
}

const char* kStyle = R"(body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}
th{background:#f0f0f0}td:first-child{text-align:left}figure{margin:1em 0}img{max-width:100%;height:auto}
.bad{color:#b00020}.good{color:#1b7a1b}.warn{color:#8a5a00}figcaption{font-size:90%;color:#555})";

}  // namespace

void render_report_html(store::Store& store, const json& summary, const fs::path& dir,
                        const std::string& gnuplot) {
  Plotter plot(dir, gnuplot);
  const std::string title = summary.value("report", "report") + " — " + summary.value("date", "");
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>"
    << html_escape(title) << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n<h1>"
    << html_escape(title) << "</h1>\n";
  if (!summary.value("description", "").empty())
    h << "<p>" << html_escape(summary.value("description", "")) << "</p>\n";
  h << "<p>Generated " << html_escape(summary.value("generated_at", "")) << " from the store "
    << "<code>" << html_escape(summary.value("db", "")) << "</code>. All numbers are in "
    << "<a href=\"summary.json\">summary.json</a>.</p>\n";

  // Overview and failure counts.
  const json entries = summary.value("entries", json::object());
  const json order = summary.value("entry_order", json::array());
  h << "<section id=\"overview\"><h2>Studies and failures</h2>\n<table><tr><th>entry</th>"
       "<th>kind</th><th>study</th><th>runs</th><th>ok</th><th>failed</th><th>missing</th>"
       "<th>computed tonight</th><th>wall [s]</th></tr>\n";
  for (const json& idj : order) {
    const std::string id = idj;
    const json& e = entries[id];
    const json c = e["counts"];
    h << "<tr><td><a href=\"#entry-" << html_escape(safe_name(id)) << "\">" << html_escape(id)
      << "</a></td><td>" << html_escape(e.value("kind", "")) << "</td><td>"
      << html_escape(e.value("study_id", "")) << "</td><td>" << c.value("total", 0) << "</td><td>"
      << c.value("ok", 0) << "</td><td" << (c.value("failed", 0) ? " class=\"bad\"" : "") << ">"
      << c.value("failed", 0) << "</td><td>" << c.value("missing", 0) << "</td><td>"
      << e["run"].value("computed", 0) << "</td><td>" << fmt(e["run"]["wall_s"], "%.1f")
      << "</td></tr>\n";
  }
  h << "</table>\n<p>Failed runs in total: <strong>"
    << summary["failures"].value("total", 0) << "</strong>.</p>\n";
  for (const json& idj : order) {
    const json& f = entries[idj.get<std::string>()]["failures"];
    if (f["first"].empty()) continue;
    h << "<p>" << html_escape(idj.get<std::string>()) << ": ";
    for (const auto& [st, n] : f["by_status"].items()) h << n.get<int>() << " " << html_escape(st) << " ";
    h << "</p><ul>";
    for (const json& r : f["first"])
      h << "<li>design index " << r.value("design_index", -1) << " (" << html_escape(r.value("status", ""))
        << "): " << html_escape(r.value("error", "")) << "</li>";
    h << "</ul>\n";
  }
  h << "</section>\n";

  h << changes_section(summary.value("changes", json::object()));

  for (const json& idj : order) {
    const std::string id = idj;
    const json& e = entries[id];
    h << "<section id=\"entry-" << html_escape(safe_name(id)) << "\"><h2>"
      << html_escape(e.value("title", id)) << "</h2>\n<p>Study <code>"
      << html_escape(e.value("study_id", "")) << "</code> (" << html_escape(e.value("study_name", ""))
      << ", spec " << html_escape(e.value("spec_source", "")) << ", hash "
      << html_escape(e.value("spec_hash", "")) << "), state " << html_escape(e.value("state", ""))
      << ".</p>\n";
    const std::string kind = e.value("kind", "");
    if (kind == "map") h << map_section(plot, id, e["map"]);
    else if (kind == "traces") h << traces_section(plot, store, id, e);
    else if (kind == "indices") h << indices_section(plot, id, e["indices"]);
    h << "</section>\n";
  }
  h << "</body>\n</html>\n";
  std::ofstream out(dir / "index.html", std::ios::binary | std::ios::trunc);
  out << h.str();
  if (!out.flush()) throw std::runtime_error("cannot write " + (dir / "index.html").string());
}

}  // namespace stickslip::reports
