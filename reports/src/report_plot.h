#pragma once
// Internal to stickslip_reports: helpers of the report's HTML and gnuplot plots, shared by
// report_html.cpp (page, maps, traces, changes) and report_indices.cpp (indices).
//
// Heat maps are drawn as discrete cells: cell (row r, column c) is a filled rectangle
// [c - 1/2, c + 1/2] x [r - 1/2, r + 1/2] (gnuplot boxxyerror), one SVG rectangle each, so colours
// never blend between rows or columns. (gnuplot's `with image` embeds a bitmap that browsers
// smooth when they scale it: that blended the map's model rows, which are categories.)
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace stickslip::reports::detail {

std::string html_escape(std::string_view s);
/// A gnuplot double-quoted literal (titles, labels); "\n" inside stays a line break.
std::string gp_quote(std::string_view s);
/// A number for gnuplot data ("NaN" when not finite).
std::string g(double v);
std::string g(const nlohmann::json& j);
/// A number for HTML ("&ndash;" when not a number).
std::string fmt(const nlohmann::json& j, const char* f = "%.4g");
/// s with every character but [A-Za-z0-9_-] replaced by '-' (file names).
std::string safe_name(std::string s);

/// Writes plots with gnuplot into dir/plots and returns the HTML figures embedding them.
class Plotter {
 public:
  Plotter(std::filesystem::path dir, std::string gnuplot);
  /// Renders 'body' (gnuplot commands after terminal/output) to plots/<name>.svg and returns the
  /// <figure> element embedding it (base64 data: URI). Throws std::runtime_error when gnuplot fails.
  std::string figure(const std::string& name, int width, int height, const std::string& body,
                     const std::string& caption);

 private:
  std::filesystem::path dir_;
  std::string gnuplot_;
};

struct Heatmap {
  std::vector<std::string> columns;            ///< x tic labels, left to right
  std::vector<std::string> rows;               ///< y tic labels, bottom to top
  std::vector<std::vector<double>> value;      ///< [row][column]; NaN: a blank cell
  std::vector<std::vector<std::string>> text;  ///< [row][column] label ("" none); may be empty
  std::size_t column_tic_every = 1;            ///< label every k-th column
  std::string xlabel, cblabel, title;
  std::string palette = "rgb 33,13,10";        ///< a gnuplot `set palette` argument
  double cbmin = 0.0, cbmax = 0.0;             ///< colour range; equal: automatic
};

/// The gnuplot commands (data blocks, settings, plot) drawing h (see above).
std::string heatmap_script(const Heatmap& h);

/// The indices section of an entry (report_indices.cpp).
std::string indices_section(Plotter& plot, const std::string& id, const nlohmann::json& ind);

}  // namespace stickslip::reports::detail
