// Measured datasets: manifest (JSON Schema via valijson) plus numeric CSV files.
//
// The CSV reader is hand-written on purpose: the files are plain numeric tables (a header row,
// then numbers, no quoting), and every problem must name the file, the 1-based line and the
// column, which a generic CSV library does not give us; Debian's libcsv is a callback parser
// without per-cell line numbers, so it would save nothing.
#include "stickslip/measured/measured.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cmath>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>

#include <nlohmann/json.hpp>

#include "stickslip/measured/measured_schema_data.h"

namespace stickslip::measured {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string join_errors(const std::vector<common::SpecError>& errors) {
  std::string out = "invalid measured dataset:";
  for (const auto& e : errors)
    out += "\n  " + (e.pointer.empty() ? std::string("(document)") : e.pointer) + ": " + e.message;
  return out;
}

std::string trim(std::string_view s) {
  std::size_t a = 0, b = s.size();
  while (a < b && (s[a] == ' ' || s[a] == '\t' || s[a] == '\r' || s[a] == '"')) ++a;
  while (b > a && (s[b - 1] == ' ' || s[b - 1] == '\t' || s[b - 1] == '\r' || s[b - 1] == '"'))
    --b;
  return std::string(s.substr(a, b - a));
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(trim(std::string_view(line).substr(start, comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return cells;
}

// Parses a whole cell as a double (accepts "nan"/"inf" so that they can be reported as such).
bool parse_double(const std::string& cell, double& out) {
  if (cell.empty()) return false;
  const char* first = cell.data();
  const char* last = first + cell.size();
  if (*first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, last, out);
  return ec == std::errc() && ptr == last;
}

// Reads one CSV from in; appends problems to errors (pointer = the file, each message starts
// with where, the file's name, and the 1-based line). The same checks for files on disk and for
// CSV text sent to the server.
void read_csv(std::istream& in, const std::string& where, const std::string& pointer,
              MeasuredRun& run, std::vector<common::SpecError>& errors) {
  std::string line;
  std::size_t line_no = 0;
  // Header: the first non-empty line.
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++line_no;
    if (!trim(line).empty()) {
      header = split(line);
      break;
    }
  }
  if (header.empty()) {
    errors.push_back({pointer, where + ": empty file (expected a header row with t and Fd)"});
    return;
  }
  if (!header.empty() && header[0].size() >= 3 && header[0].compare(0, 3, "\xEF\xBB\xBF") == 0)
    header[0].erase(0, 3);  // UTF-8 byte order mark
  const auto col = [&](const char* name) -> long {
    const auto it = std::find(header.begin(), header.end(), name);
    return it == header.end() ? -1 : static_cast<long>(it - header.begin());
  };
  const long ct = col("t"), cf = col("Fd");
  bool missing = false;
  for (auto [name, c] : {std::pair{"t", ct}, std::pair{"Fd", cf}}) {
    if (c >= 0) continue;
    std::string have;
    for (const auto& h : header) have += (have.empty() ? "" : ", ") + h;
    errors.push_back({pointer, where + ":" + std::to_string(line_no) + ": missing column '" +
                                   name + "' (header has: " + have + ")"});
    missing = true;
  }
  if (missing) return;
  const std::size_t need = static_cast<std::size_t>(std::max(ct, cf)) + 1;
  std::size_t reported = 0;  // keep the list readable on a badly broken file
  const auto report = [&](const std::string& msg) {
    if (reported++ < 10) errors.push_back({pointer, where + ":" + std::to_string(line_no) + ": " + msg});
  };
  while (std::getline(in, line)) {
    ++line_no;
    if (trim(line).empty()) continue;
    const auto cells = split(line);
    if (cells.size() < need) {
      report("expected at least " + std::to_string(need) + " columns, got " +
             std::to_string(cells.size()));
      continue;
    }
    double t = 0, f = 0;
    bool ok = true;
    for (auto [name, c, out] : {std::tuple{"t", ct, &t}, std::tuple{"Fd", cf, &f}}) {
      if (!parse_double(cells[c], *out)) {
        report("column '" + std::string(name) + "': '" + cells[c] + "' is not a number");
        ok = false;
      } else if (!std::isfinite(*out)) {
        report("column '" + std::string(name) + "': " + cells[c] + " is not finite");
        ok = false;
      }
    }
    if (!ok) continue;
    if (!run.t.empty() && !(t > run.t.back())) {
      std::ostringstream m;
      m.precision(17);
      m << "t = " << t << " does not increase (previous t = " << run.t.back() << ")";
      report(m.str());
      continue;
    }
    run.t.push_back(t);
    run.Fd.push_back(f);
  }
  if (reported > 10)
    errors.push_back({pointer, where + ": " + std::to_string(reported - 10) + " more problems"});
  if (reported == 0 && run.t.size() < kMinMeasuredSamples)
    errors.push_back({pointer, where + ": " + std::to_string(run.t.size()) +
                                   " samples, need at least " +
                                   std::to_string(kMinMeasuredSamples)});
}

const json& measured_schema() {
  static const json schema = json::parse(generated::kMeasuredSchemaJson);
  return schema;
}

}  // namespace

MeasuredError::MeasuredError(std::vector<common::SpecError> errors)
    : std::runtime_error(join_errors(errors)), errors_(std::move(errors)) {}

namespace {

/// Where build_dataset gets a run's CSV: reads it into run (appending problems to errors).
using CsvReader = std::function<void(std::size_t index, const std::string& run_pointer,
                                     MeasuredRun& run, std::vector<common::SpecError>& errors)>;

/// The manifest's condition keys, their fields and units (defaulted_text).
struct ConditionField {
  const char* key;
  double MeasuredConditions::*field;
  const char* unit;
};
constexpr ConditionField kConditionFields[] = {
    {"m", &MeasuredConditions::m, "kg"},         {"kd", &MeasuredConditions::kd, "N/m"},
    {"vd", &MeasuredConditions::vd, "m/s"},      {"Fz", &MeasuredConditions::Fz, "N"},
    {"f", &MeasuredConditions::f, "Hz"},         {"va", &MeasuredConditions::va, "m/s"},
    {"t_on", &MeasuredConditions::t_on, "s"},    {"duration", &MeasuredConditions::duration, "s"}};

/// The manifest's runs, their conditions and their CSVs; schema errors are reported with
/// pointers prefixed by prefix ("" for a manifest file, "/manifest" inside a server request).
/// Throws MeasuredError listing every problem.
MeasuredDataset build_dataset(const json& doc, const std::string& prefix, const CsvReader& csv) {
  std::vector<common::SpecError> errors = common::validate_against_schema(doc, measured_schema());
  if (!errors.empty()) {
    for (auto& e : errors) e.pointer = prefix + e.pointer;
    throw MeasuredError(std::move(errors));
  }
  MeasuredDataset ds;
  ds.name = doc.at("name").get<std::string>();
  const json& runs = doc.at("runs");
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const json& r = runs[i];
    const std::string ptr = prefix + "/runs/" + std::to_string(i);
    MeasuredRun run;
    run.name = r.at("name").get<std::string>();
    run.file = r.at("file").get<std::string>();
    for (std::size_t j = 0; j < ds.runs.size(); ++j)
      if (ds.runs[j].name == run.name)
        errors.push_back({ptr + "/name", "duplicate run name '" + run.name + "' (also " + prefix +
                                             "/runs/" + std::to_string(j) + ")"});
    const auto it = r.find("conditions");
    for (const ConditionField& f : kConditionFields) {
      if (it != r.end() && it->contains(f.key))
        run.conditions.*f.field = it->at(f.key).get<double>();
      else
        run.conditions.defaulted.push_back(f.key);
    }
    if (run.conditions.t_on > run.conditions.duration)
      errors.push_back({ptr + "/conditions/t_on",
                        "t_on = " + std::to_string(run.conditions.t_on) +
                            " s is after the end of the run (duration = " +
                            std::to_string(run.conditions.duration) + " s)"});
    csv(i, ptr, run, errors);
    ds.runs.push_back(std::move(run));
  }
  if (!errors.empty()) throw MeasuredError(std::move(errors));
  return ds;
}

/// A plain file name: no directory part, no "." or "..", no control characters.
bool is_plain_file_name(const std::string& name) {
  if (name.empty() || name == "." || name == ".." || name.size() > 255) return false;
  for (const char c : name)
    if (c == '/' || c == '\\' || static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return false;
  return true;
}

}  // namespace

MeasuredDataset load_measured(const fs::path& manifest) {
  std::error_code ec;
  fs::path absolute = fs::absolute(manifest, ec);
  if (ec) absolute = manifest;
  std::ifstream in(manifest);
  if (!in) throw MeasuredError({{"", "cannot open manifest '" + manifest.string() + "'"}});
  std::stringstream buffer;
  buffer << in.rdbuf();
  json doc;
  if (common::json_nesting_depth(buffer.str()) > common::kMaxJsonDepth)
    throw MeasuredError({{"", manifest.string() + ": arrays and objects are nested more than " +
                                  std::to_string(common::kMaxJsonDepth) + " levels deep"}});
  try {
    doc = json::parse(buffer.str());
  } catch (const json::parse_error& e) {
    throw MeasuredError({{"", manifest.string() + ": malformed JSON: " + e.what()}});
  }
  const fs::path dir = absolute.parent_path();
  MeasuredDataset ds = build_dataset(
      doc, "", [&](std::size_t, const std::string& ptr, MeasuredRun& run,
                   std::vector<common::SpecError>& errors) {
        fs::path file = run.file;
        if (file.is_relative()) file = dir / file;
        std::ifstream csv(file);
        if (!csv) {
          errors.push_back({ptr + "/file", "cannot open file '" + file.string() + "'"});
          return;
        }
        read_csv(csv, file.string(), ptr + "/file", run, errors);
      });
  ds.manifest = absolute;
  return ds;
}

MeasuredDataset load_measured(const json& manifest, const std::map<std::string, std::string>& files) {
  // Every file name first, so that a path-like name is reported even when its run has other
  // problems too.
  std::vector<common::SpecError> errors;
  for (const auto& [name, text] : files) {
    if (!is_plain_file_name(name))
      errors.push_back({common::pointer_append("/files", name),
                        "'" + name + "' is not a plain file name (no '/', '\\', '.' or '..'; "
                                     "1 to 255 characters)"});
  }
  std::vector<bool> used(files.size(), false);
  bool schema_ok = false;  // build_dataset reached the CSVs
  MeasuredDataset ds;
  try {
    ds = build_dataset(manifest, "/manifest", [&](std::size_t, const std::string& ptr,
                                                  MeasuredRun& run, std::vector<common::SpecError>& errs) {
      schema_ok = true;
      if (!is_plain_file_name(run.file)) {
        errs.push_back({ptr + "/file", "'" + run.file + "' is not a plain file name: a request "
                                       "carries its CSVs in /files, not as paths"});
        return;
      }
      const auto it = files.find(run.file);
      if (it == files.end()) {
        errs.push_back({ptr + "/file", "no content for file '" + run.file + "' in /files"});
        return;
      }
      used[static_cast<std::size_t>(std::distance(files.begin(), it))] = true;
      std::istringstream csv(it->second);
      read_csv(csv, run.file, common::pointer_append("/files", run.file), run, errs);
    });
  } catch (const MeasuredError& e) {
    errors.insert(errors.end(), e.errors().begin(), e.errors().end());
  }
  if (schema_ok) {
    std::size_t i = 0;
    for (const auto& [name, text] : files) {
      if (!used[i++] && is_plain_file_name(name))
        errors.push_back({common::pointer_append("/files", name),
                          "file '" + name + "' is not named by any run of /manifest/runs"});
    }
  }
  if (!errors.empty()) throw MeasuredError(std::move(errors));
  return ds;
}

std::string defaulted_text(const MeasuredConditions& c) {
  std::string out;
  for (const std::string& key : c.defaulted)
    for (const ConditionField& f : kConditionFields)
      if (key == f.key) {
        char buf[96];
        std::snprintf(buf, sizeof buf, "%s%s = %g %s", out.empty() ? "" : ", ", f.key, c.*f.field, f.unit);
        out += buf;
      }
  return out;
}

void apply_conditions(const MeasuredConditions& c, engine::SimConfig& cfg) {
  cfg.drive.m = c.m;
  cfg.drive.k_d = c.kd;
  cfg.drive.v_d = c.vd;
  cfg.drive.F_z = c.Fz;
  cfg.stages.clear();
  if (c.t_on > 0.0) cfg.stages.push_back(engine::Stage{std::min(c.t_on, c.duration), 0.0, c.f});
  if (c.t_on < c.duration) cfg.stages.push_back(engine::Stage{c.duration - c.t_on, c.va, c.f});
}

namespace {
bool close(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b)); }
// The times at which the base motion changes, with what it becomes; adjacent equal stages and
// the frequency of still stages do not matter.
std::vector<std::tuple<double, double, double>> motion(const std::vector<engine::Stage>& stages) {
  std::vector<std::tuple<double, double, double>> out;  // (t_start, v_a, f)
  double t = 0.0;
  for (const engine::Stage& s : stages) {
    const double f = s.v_a > 0.0 ? s.f : 0.0;
    if (out.empty() || !close(std::get<1>(out.back()), s.v_a) || !close(std::get<2>(out.back()), f))
      out.emplace_back(t, s.v_a, f);
    t += s.duration;
  }
  out.emplace_back(t, -1.0, -1.0);  // end marker
  return out;
}
}  // namespace

bool matches_conditions(const engine::SimConfig& cfg, const MeasuredConditions& c) {
  if (!close(cfg.drive.m, c.m) || !close(cfg.drive.k_d, c.kd) || !close(cfg.drive.v_d, c.vd) ||
      !close(cfg.drive.F_z, c.Fz))
    return false;
  engine::SimConfig want = cfg;
  apply_conditions(c, want);
  const auto a = motion(cfg.stages), b = motion(want.stages);
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!close(std::get<0>(a[i]), std::get<0>(b[i])) || !close(std::get<1>(a[i]), std::get<1>(b[i])) ||
        !close(std::get<2>(a[i]), std::get<2>(b[i])))
      return false;
  return true;
}

double rmse_window(const std::vector<double>& t, const std::vector<double>& Fd,
                   const std::vector<double>& ts, const std::vector<double>& Fs, double t0,
                   double t1) {
  if (ts.empty()) return std::nan("");
  double sum = 0.0;
  std::size_t n = 0, j = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i] < t0 || t[i] >= t1) continue;
    while (j + 1 < ts.size() && ts[j + 1] <= t[i]) ++j;
    double sim;
    if (t[i] <= ts.front()) sim = Fs.front();
    else if (j + 1 >= ts.size()) sim = Fs.back();
    else {
      const double w = (t[i] - ts[j]) / (ts[j + 1] - ts[j]);
      sim = Fs[j] + w * (Fs[j + 1] - Fs[j]);
    }
    const double e = Fd[i] - sim;
    sum += e * e;
    ++n;
  }
  return n == 0 ? std::nan("") : std::sqrt(sum / static_cast<double>(n));
}

}  // namespace stickslip::measured
