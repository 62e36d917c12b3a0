// Helpers of the nightly report's HTML (see report_plot.h): escaping, number formats, the gnuplot
// figure writer and the categorical heat map.
#include "report_plot.h"

#include <boost/archive/iterators/base64_from_binary.hpp>
#include <boost/archive/iterators/transform_width.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "stickslip/common/gnuplot.h"

namespace stickslip::reports::detail {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::string base64(const std::string& bytes) {
  using namespace boost::archive::iterators;
  using It = base64_from_binary<transform_width<std::string::const_iterator, 6, 8>>;
  std::string out(It(bytes.begin()), It(bytes.end()));
  out.append((3 - bytes.size() % 3) % 3, '=');
  return out;
}

// Runs gnuplot on a script file (common::run_gnuplot: no shell); stderr goes to a file that is
// quoted in the error when gnuplot fails.
void run_gnuplot(const std::string& gnuplot, const fs::path& script) {
  const fs::path err = script.string() + ".stderr";
  common::GnuplotCall call;
  call.executable = gnuplot;
  call.script = script;
  call.log = err;
  const int status = common::run_gnuplot(call);
  std::ifstream in(err);
  std::stringstream msg;
  msg << in.rdbuf();
  if (status != 0)
    throw std::runtime_error("gnuplot failed on " + script.string() +
                             (status == common::kGnuplotNotFound
                                  ? " ('" + gnuplot + "' not found; install gnuplot-nox)"
                                  : "") +
                             ": " + msg.str());
  std::error_code ec;
  fs::remove(err, ec);
  fs::remove(script, ec);
}

}  // namespace

std::string html_escape(std::string_view s) {
  std::string o;
  o.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&#39;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string gp_quote(std::string_view s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '\n') {  // a line break in a label
      o += "\\n";
      continue;
    }
    if (c == '"' || c == '\\') o += '\\';
    if (c == '_' || c == '^' || c == '{' || c == '}' || c == '@' || c == '&') o += "\\\\";
    o += c;
  }
  return o + "\"";
}

std::string g(double v) {
  if (!std::isfinite(v)) return "NaN";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string g(const json& j) { return j.is_number() ? g(j.get<double>()) : "NaN"; }

std::string fmt(const json& j, const char* f) {
  if (!j.is_number()) return "&ndash;";
  char buf[40];
  std::snprintf(buf, sizeof buf, f, j.get<double>());
  return buf;
}

std::string safe_name(std::string s) {
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '-';
  return s;
}

Plotter::Plotter(fs::path dir, std::string gnuplot)
    : dir_(std::move(dir)), gnuplot_(std::move(gnuplot)) {
  fs::create_directories(dir_ / "plots");
}

std::string Plotter::figure(const std::string& name, int width, int height,
                            const std::string& body, const std::string& caption) {
  const std::string file = "plots/" + safe_name(name) + ".svg";
  const fs::path script = dir_ / ("plots/" + safe_name(name) + ".gp");
  {
    std::ofstream gp(script);
    gp << "set terminal svg size " << width << "," << height
       << " dynamic enhanced font 'sans,11' background rgb 'white'\n"
       << "set output '" << (dir_ / file).string() << "'\n"
       << body << "\nunset output\n";
  }
  run_gnuplot(gnuplot_, script);
  std::ifstream in(dir_ / file, std::ios::binary);
  std::stringstream svg;
  svg << in.rdbuf();
  if (svg.str().find("<svg") == std::string::npos)
    throw std::runtime_error("gnuplot wrote no SVG to " + (dir_ / file).string());
  return "<figure><img src=\"data:image/svg+xml;base64," + base64(svg.str()) + "\" alt=\"" +
         html_escape(caption) + "\" data-plot=\"" + file + "\" width=\"" +
         std::to_string(width) + "\" height=\"" + std::to_string(height) +
         "\"><figcaption>" + html_escape(caption) + "</figcaption></figure>\n";
}

std::string heatmap_script(const Heatmap& h) {
  std::ostringstream b;
  b << "$cells << EOD\n";
  for (std::size_t r = 0; r < h.rows.size(); ++r)
    for (std::size_t c = 0; c < h.columns.size(); ++c) b << c << ' ' << r << ' ' << g(h.value[r][c]) << '\n';
  b << "EOD\n$labels << EOD\n";
  for (std::size_t r = 0; r < h.text.size(); ++r)
    for (std::size_t c = 0; c < h.text[r].size(); ++c)
      if (!h.text[r][c].empty()) b << c << ' ' << r << ' ' << gp_quote(h.text[r][c]) << '\n';
  b << "EOD\nset xrange [-0.5:" << h.columns.size() - 0.5 << "]\nset yrange [-0.5:"
    << h.rows.size() - 0.5 << "]\nset xtics (";
  const std::size_t every = std::max<std::size_t>(1, h.column_tic_every);
  for (std::size_t c = 0; c < h.columns.size(); c += every)
    b << (c ? ", " : "") << gp_quote(h.columns[c]) << ' ' << c;
  b << ")\nset ytics (";
  for (std::size_t r = 0; r < h.rows.size(); ++r) b << (r ? ", " : "") << gp_quote(h.rows[r]) << ' ' << r;
  b << ")\nset tics scale 0\nset xlabel " << gp_quote(h.xlabel) << "\nset cblabel "
    << gp_quote(h.cblabel) << "\nset title " << gp_quote(h.title) << "\nset palette "
    << h.palette << "\n";
  if (h.cbmax > h.cbmin) b << "set cbrange [" << g(h.cbmin) << ":" << g(h.cbmax) << "]\n";
  b << "set style fill solid 1.0 noborder\nset style textbox opaque noborder\n"
    << "plot $cells using 1:2:(0.5):(0.5):3 with boxxyerror lc palette notitle";
  if (!h.text.empty()) b << ", $labels using 1:2:3 with labels boxed font ',9' notitle";
  b << "\n";
  return b.str();
}

}  // namespace stickslip::reports::detail
