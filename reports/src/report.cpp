// The nightly report: configuration, running the studies, summary.json and the night-to-night
// comparison (see report.h). The HTML and its plots are in report_html.cpp.
#include "stickslip/common/json_number.h"
#include "stickslip/reports/report.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "stickslip/studies/map.h"
#include "stickslip/reports/report_schema_data.h"  // generated at build time

namespace stickslip::reports {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::optional<std::string> read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return std::nullopt;
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}


// j[key] by reference, or an empty array when missing (never a temporary: callers keep pointers
// into the result).
const json& array_at(const json& j, const char* key) {
  static const json empty = json::array();
  const auto it = j.find(key);
  return it != j.end() && it->is_array() ? *it : empty;
}

// A JSON number or null as double (NaN for null).
double as_double(const json& j) { return j.is_number() ? j.get<double>() : std::nan(""); }

}  // namespace

const char* to_string(EntryKind k) noexcept {
  switch (k) {
    case EntryKind::kMap: return "map";
    case EntryKind::kTraces: return "traces";
    case EntryKind::kIndices: return "indices";
  }
  return "?";
}

const nlohmann::json& report_schema() {
  static const json schema = json::parse(generated::kReportSchemaJson);
  return schema;
}

bool is_valid_date(std::string_view date) {
  static const std::regex re(R"(\d{4}-\d{2}-\d{2})");
  if (!std::regex_match(date.begin(), date.end(), re)) return false;
  const int y = std::stoi(std::string(date.substr(0, 4)));
  const unsigned m = static_cast<unsigned>(std::stoi(std::string(date.substr(5, 2))));
  const unsigned d = static_cast<unsigned>(std::stoi(std::string(date.substr(8, 2))));
  return std::chrono::year_month_day{std::chrono::year{y}, std::chrono::month{m},
                                     std::chrono::day{d}}
      .ok();
}

std::string utc_today() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[16];
  std::strftime(buf, sizeof buf, "%Y-%m-%d", &tm);
  return buf;
}

// ------------------------------------------------------------------------------ configuration

namespace {

using SpecErrors = std::vector<common::SpecError>;

/// The text of an entry's study spec: the file it names (relative to the config's directory) or
/// the inline object. Sets entry.spec_source and entry.spec_dir; nullopt, with the error, when
/// the file cannot be read.
std::optional<std::string> entry_spec_text(const json& e, const std::string& at,
                                           const fs::path& config_dir, ReportEntry& entry,
                                           SpecErrors& errors) {
  if (e.at("spec").is_string()) {
    entry.spec_source = e["spec"].get<std::string>();
    fs::path p = entry.spec_source;
    if (p.is_relative()) p = config_dir / p;
    auto t = read_file(p);
    if (!t) {
      errors.push_back({at + "/spec", "cannot read study file '" + p.string() + "'"});
      return std::nullopt;
    }
    entry.spec_dir = p.parent_path();
    return t;
  }
  entry.spec_source = "(inline)";
  entry.spec_dir = config_dir;
  return e["spec"].dump();
}

/// What an entry of kind `kind` needs of its parsed spec (a sampled design for indices, a grid
/// for maps and traces, kept traces) and its outputs (indices only, each one the study has).
void check_entry(const json& e, const std::string& at, const std::string& kind, ReportEntry& entry,
                 SpecErrors& errors) {
  const studies::DesignType type = entry.spec->design().type;
  if (entry.kind == EntryKind::kIndices &&
      (type == studies::DesignType::kGrid || type == studies::DesignType::kList))
    errors.push_back({at + "/spec", std::string("an indices entry needs a sampled design "
                                                "(sobol, morris, efast, rbd_fast, dgsm, "
                                                "random or lhs), got '") +
                                        to_string(type) + "'"});
  if (entry.kind != EntryKind::kIndices && type != studies::DesignType::kGrid)
    errors.push_back({at + "/spec", std::string("a ") + kind + " entry needs a grid design, got '" +
                                        to_string(type) + "'"});
  if (entry.kind == EntryKind::kTraces && entry.spec->trace_rate() <= 0)
    errors.push_back({at + "/spec", "a traces entry needs a study that keeps traces "
                                    "(outputs.traces.rate)"});
  if (e.contains("outputs")) {
    if (entry.kind != EntryKind::kIndices)
      errors.push_back({at + "/outputs", "only indices entries take outputs"});
    for (std::size_t k = 0; k < e["outputs"].size(); ++k) {
      const std::string o = e["outputs"][k].get<std::string>();
      if (const std::string why = studies::check_output(*entry.spec, o); !why.empty())
        errors.push_back({at + "/outputs/" + std::to_string(k), why});
      entry.outputs.push_back(o);
    }
  }
}

/// One entry of the config's "studies" (e, at the JSON Pointer at), schema-valid: its spec read
/// and parsed, and checked for its kind. nullopt when the spec could not be read or parsed; every
/// problem is appended to errors.
std::optional<ReportEntry> parse_entry(const json& e, const std::string& at,
                                       const fs::path& config_dir, SpecErrors& errors) {
  ReportEntry entry;
  entry.id = e.at("id").get<std::string>();
  entry.title = e.value("title", entry.id);
  const std::string kind = e.at("kind").get<std::string>();
  entry.kind = kind == "map" ? EntryKind::kMap
               : kind == "traces" ? EntryKind::kTraces
                                  : EntryKind::kIndices;
  const auto spec_text = entry_spec_text(e, at, config_dir, entry, errors);
  if (!spec_text) return std::nullopt;
  studies::ParseResult parsed = studies::parse_study(*spec_text);
  if (!parsed.ok()) {
    for (const auto& err : parsed.errors)
      errors.push_back({at + "/spec" + (e["spec"].is_string() ? "" : err.pointer),
                        (e["spec"].is_string() ? entry.spec_source + ": " + err.pointer +
                                                     (err.pointer.empty() ? "" : ": ")
                                               : std::string()) +
                            err.message});
    return std::nullopt;
  }
  entry.spec = std::make_shared<const studies::StudySpec>(std::move(*parsed.spec));
  entry.method = e.value("method", "");
  check_entry(e, at, kind, entry, errors);
  return entry;
}

}  // namespace

ReportConfigResult parse_report_config(std::string_view text, const fs::path& config_dir) {
  ReportConfigResult result;
  auto doc = common::parse_json(text, &result.errors);
  if (!doc) return result;
  static const common::SchemaValidator validator(report_schema());
  result.errors = validator.validate(*doc);
  if (!result.errors.empty()) return result;

  ReportConfig cfg;
  cfg.document = *doc;
  cfg.name = doc->at("name").get<std::string>();
  cfg.description = doc->value("description", "");
  cfg.threads = doc->value("threads", 0);
  if (doc->contains("map_tolerance")) {
    cfg.map_tolerance.abs = (*doc)["map_tolerance"].value("abs", cfg.map_tolerance.abs);
    cfg.map_tolerance.rel = (*doc)["map_tolerance"].value("rel", cfg.map_tolerance.rel);
  }
  if (doc->contains("indices")) {
    cfg.indices.confidence = (*doc)["indices"].value("confidence", cfg.indices.confidence);
    cfg.indices.resamples = (*doc)["indices"].value("resamples", cfg.indices.resamples);
  }
  std::set<std::string> ids;
  const json& studies = doc->at("studies");
  for (std::size_t i = 0; i < studies.size(); ++i) {
    const std::string at = "/studies/" + std::to_string(i);
    const std::string id = studies[i].at("id").get<std::string>();
    if (!ids.insert(id).second)
      result.errors.push_back({at + "/id", "duplicate entry id \"" + id + "\""});
    if (auto entry = parse_entry(studies[i], at, config_dir, result.errors))
      cfg.entries.push_back(std::move(*entry));
  }
  if (result.errors.empty()) result.config = std::move(cfg);
  return result;
}

bool ReportOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (db.empty()) return fail("db: no database path");
  if (out_dir.empty()) return fail("out: no output directory");
  if (!date.empty() && !is_valid_date(date))
    return fail("date: expected a calendar date YYYY-MM-DD, got '" + date + "'");
  if (gnuplot.empty()) return fail("gnuplot: no executable");
  return true;
}

// ------------------------------------------------------------------------------ running

std::vector<EntryRun> run_report_studies(const ReportConfig& config, const ReportOptions& options) {
  std::vector<EntryRun> out;
  for (const ReportEntry& e : config.entries) {
    EntryRun r;
    r.entry_id = e.id;
    {
      store::Store store = store::Store::open(options.db);
      r.study_id = studies::create_or_find_study(store, *e.spec).id;
    }
    studies::RunnerOptions ro;
    ro.threads = options.threads >= 0 ? options.threads : config.threads;
    ro.spec_dir = e.spec_dir;
    ro.stop = options.stop;
    ro.execution = options.execution;
    if (options.on_progress)
      ro.on_progress = [&](const studies::Progress& p) { options.on_progress(e.id, p); };
    r.run = studies::run_study(options.db, r.study_id, *e.spec, ro);
    out.push_back(std::move(r));
    if (out.back().run.outcome != studies::RunOutcome::kCompleted) break;
  }
  return out;
}

// ------------------------------------------------------------------------------ summary

json make_summary(store::Store& store, const ReportConfig& config, const std::vector<EntryRun>& runs,
                  const std::string& date) {
  json s{{"report", config.name},
         {"description", config.description},
         {"date", date},
         {"generated_at", store::utc_now_iso8601()},
         {"db", store.path().string()},
         {"config", config.document},
         {"map_tolerance", {{"abs", config.map_tolerance.abs}, {"rel", config.map_tolerance.rel}}}};
  json entries = json::object(), order = json::array(), by_entry = json::object();
  std::int64_t failures_total = 0;
  for (const ReportEntry& e : config.entries) {
    const auto it = std::find_if(runs.begin(), runs.end(),
                                 [&](const EntryRun& r) { return r.entry_id == e.id; });
    if (it == runs.end()) continue;
    const auto study = store.get_study(it->study_id);
    if (!study) throw store::StoreError("study " + it->study_id + " vanished from " + store.path().string());
    const store::RunCounts c = store.count_runs(study->id);
    json j{{"kind", to_string(e.kind)},
           {"title", e.title},
           {"spec_source", e.spec_source},
           {"study_id", study->id},
           {"study_name", study->name},
           {"spec_hash", study->spec_hash},
           {"state", to_string(study->state)},
           {"counts", {{"total", c.total}, {"ok", c.ok}, {"failed", c.failed},
                       {"missing", c.total - c.done}}},
           {"run", {{"outcome", to_string(it->run.outcome)},
                    {"computed", it->run.computed},
                    {"skipped", it->run.skipped},
                    {"failed", it->run.failed},
                    {"wall_s", it->run.wall_s},
                    {"compute_s", it->run.compute_s}}}};
    // Failed runs by status and the first few reasons (failure counts section).
    json reasons = json::array();
    std::map<std::string, std::int64_t> by_status;
    std::int64_t after = -1;
    while (c.failed > 0) {
      const auto page = store.get_runs(study->id, after, 2000);
      if (page.empty()) break;
      for (const store::RunRecord& r : page) {
        after = r.design_index;
        if (r.status == "ok") continue;
        ++by_status[r.status];
        if (reasons.size() < 20)
          reasons.push_back({{"design_index", r.design_index}, {"status", r.status},
                             {"error", r.error}});
      }
    }
    j["failures"] = {{"by_status", by_status}, {"first", reasons}};
    failures_total += c.failed;
    by_entry[e.id] = c.failed;
    if (e.kind == EntryKind::kIndices) {
      studies::IndicesOptions io = config.indices;
      io.method = e.method;
      io.convergence = e.spec->design().type == studies::DesignType::kSobol &&
                       (e.method.empty() || e.method == "sobol");
      j["indices"] = studies::indices_json(store, study->id, e.outputs, io);
    } else {
      j["map"] = studies::map_to_json(studies::build_map(store, study->id));
      if (e.kind == EntryKind::kTraces) {
        json traces = json::array();
        for (std::int64_t i = 0; i < c.total; ++i) {
          const studies::DesignPoint p = e.spec->point(static_cast<std::size_t>(i));
          const auto t = store.get_trace(study->id, i);
          traces.push_back({{"design_index", i},
                            {"point", e.spec->point_json(p)},
                            {"samples", t ? t->size() : 0}});
        }
        j["traces"] = traces;
      }
    }
    entries[e.id] = std::move(j);
    order.push_back(e.id);
  }
  s["entries"] = entries;
  s["entry_order"] = order;
  s["failures"] = {{"total", failures_total}, {"by_entry", by_entry}};
  return s;
}

// ------------------------------------------------------------------------------ comparison

namespace {

// The interval of one index as [lo, hi], or nullopt when either end is null.
std::optional<std::pair<double, double>> interval_of(const json& ci) {
  if (!ci.is_array() || ci.size() != 2 || !ci[0].is_number() || !ci[1].is_number())
    return std::nullopt;
  return std::make_pair(ci[0].get<double>(), ci[1].get<double>());
}

void compare_indices(const std::string& entry, const json& prev, const json& cur, json& flags,
                     json& notes) {
  std::map<std::string, const json*> prev_out;
  for (const auto& o : array_at(prev, "outputs")) prev_out[o.value("output", "")] = &o;
  for (const auto& o : array_at(cur, "outputs")) {
    const std::string name = o.value("output", "");
    const auto it = prev_out.find(name);
    if (it == prev_out.end()) {
      notes.push_back(entry + ": output " + name + " is new");
      continue;
    }
    const json& p = *it->second;
    // Summaries written before "status" existed have only "valid".
    auto status = [](const json& out) {
      return out.value("status", std::string(out.value("valid", false) ? "ok" : "invalid"));
    };
    const std::string ps = status(p), cs = status(o);
    if (ps != cs) {
      flags.push_back({{"entry", entry}, {"output", name}, {"parameter", nullptr},
                       {"index", "status"}, {"previous", ps}, {"current", cs},
                       {"reason", "indices went from " + ps + " to " + cs +
                                      (cs == "ok" ? std::string() : ": " + o.value("reason", ""))}});
      continue;
    }
    if (cs != "ok") continue;
    std::map<std::string, const json*> prev_par;
    for (const auto& x : array_at(p, "indices"))
      prev_par[x.value("parameter", "")] = &x;
    for (const auto& x : array_at(o, "indices")) {
      const std::string par = x.value("parameter", "");
      const auto pit = prev_par.find(par);
      if (pit == prev_par.end()) {
        notes.push_back(entry + ": " + name + ": parameter " + par + " is new");
        continue;
      }
      for (const auto& [key, value] : x.items()) {
        if (key.size() <= 3 || key.compare(key.size() - 3, 3, "_ci") != 0) continue;
        const std::string idx = key.substr(0, key.size() - 3), ci = key;
        if (!x.contains(ci) || !pit->second->contains(ci)) continue;
        const auto a = interval_of((*pit->second)[ci]), b = interval_of(x[ci]);
        if (!a || !b) continue;
        if (b->first > a->second || b->second < a->first)
          flags.push_back({{"entry", entry},
                           {"output", name},
                           {"parameter", par},
                           {"index", idx},
                           {"previous", (*pit->second)[idx]},
                           {"previous_ci", (*pit->second)[ci]},
                           {"current", x[idx]},
                           {"current_ci", x[ci]},
                           {"reason", "confidence intervals do not overlap"}});
      }
    }
  }
}

void compare_maps(const std::string& entry, const json& prev, const json& cur,
                  const MapTolerance& tol, json& flags) {
  // cell id: model + compact row key
  std::map<std::string, std::pair<std::string, const json*>> prev_cells;
  auto cell_id = [](const std::string& model, const json& key) { return model + " " + key.dump(); };
  for (const auto& row : array_at(prev, "rows"))
    for (const auto& [model, cell] : row.at("cells").items())
      prev_cells[cell_id(model, row.at("key"))] = {model, &cell};
  std::set<std::string> seen;
  for (const auto& row : array_at(cur, "rows"))
    for (const auto& [model, cell] : row.at("cells").items()) {
      const std::string id = cell_id(model, row.at("key"));
      seen.insert(id);
      json base{{"entry", entry}, {"model", model}, {"key", row.at("key")}};
      const auto it = prev_cells.find(id);
      if (it == prev_cells.end()) {
        base["reason"] = "new cell";
        base["current_state"] = cell.value("state", "");
        flags.push_back(base);
        continue;
      }
      const json& p = *it->second.second;
      const std::string ps = p.value("state", ""), cs = cell.value("state", "");
      if (ps != cs) {
        base["reason"] = "state changed from " + ps + " to " + cs;
        base["previous_state"] = ps;
        base["current_state"] = cs;
        flags.push_back(base);
        continue;
      }
      if (cs != "ok") continue;
      const json pa = p.value("amplitude", json::array()), ca = cell.value("amplitude", json::array());
      const std::size_t stages = std::max(pa.size(), ca.size());
      for (std::size_t s = 0; s < stages; ++s) {
        const double a = s < pa.size() ? as_double(pa[s]) : std::nan("");
        const double b = s < ca.size() ? as_double(ca[s]) : std::nan("");
        if (std::isnan(a) && std::isnan(b)) continue;
        const double limit = tol.abs + tol.rel * std::abs(a);
        if (std::isnan(a) != std::isnan(b) || std::abs(b - a) > limit) {
          json f = base;
          f["stage"] = s + 1;
          f["previous"] = common::json_number(a);
          f["current"] = common::json_number(b);
          f["delta"] = common::json_number(b - a);
          f["tolerance"] = common::json_number(limit);
          f["reason"] = "amplitude moved by more than the tolerance";
          flags.push_back(f);
        }
      }
    }
  for (const auto& [id, pc] : prev_cells)
    if (!seen.count(id)) {
      const auto key_text = id.substr(pc.first.size() + 1);
      flags.push_back({{"entry", entry}, {"model", pc.first}, {"key", json::parse(key_text)},
                       {"reason", "cell disappeared"}});
    }
}

}  // namespace

json compare_summaries(const json* previous, const json& current, const MapTolerance& tolerance) {
  json changes{{"previous_date", nullptr}, {"flagged", 0}, {"indices", json::array()},
               {"map_cells", json::array()}, {"notes", json::array()},
               {"map_tolerance", {{"abs", tolerance.abs}, {"rel", tolerance.rel}}}};
  if (previous == nullptr) return changes;
  changes["previous_date"] = previous->value("date", "");
  const json pe = previous->value("entries", json::object());
  const json ce = current.value("entries", json::object());
  for (const auto& [id, cur] : ce.items()) {
    if (!pe.contains(id)) {
      changes["notes"].push_back("entry " + id + " is new");
      continue;
    }
    const json& prev = pe[id];
    if (prev.value("spec_hash", "") != cur.value("spec_hash", ""))
      changes["notes"].push_back("entry " + id + ": the study spec changed (study " +
                                 prev.value("study_id", "") + " -> " + cur.value("study_id", "") +
                                 ")");
    if (prev.value("kind", "") != cur.value("kind", "")) {
      changes["notes"].push_back("entry " + id + ": kind changed; not compared");
      continue;
    }
    if (cur.contains("indices") && prev.contains("indices")) {
      if (prev["indices"].value("method", "") != cur["indices"].value("method", ""))
        changes["notes"].push_back("entry " + id + ": method changed; indices not compared");
      else
        compare_indices(id, prev["indices"], cur["indices"], changes["indices"], changes["notes"]);
    }
    if (cur.contains("map") && prev.contains("map"))
      compare_maps(id, prev["map"], cur["map"], tolerance, changes["map_cells"]);
  }
  for (const auto& [id, prev] : pe.items())
    if (!ce.contains(id)) changes["notes"].push_back("entry " + id + " was removed");
  changes["flagged"] = changes["indices"].size() + changes["map_cells"].size();
  return changes;
}

std::optional<fs::path> find_previous_summary(const fs::path& out_dir, const std::string& date) {
  std::error_code ec;
  std::optional<std::string> best;
  for (fs::directory_iterator it(out_dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!it->is_directory() || !is_valid_date(name) || name >= date) continue;
    if (!fs::exists(it->path() / "summary.json")) continue;
    if (!best || name > *best) best = name;
  }
  if (!best) return std::nullopt;
  return out_dir / *best / "summary.json";
}

std::vector<std::string> list_report_dates(const fs::path& out_dir) {
  std::vector<std::string> dates;
  std::error_code ec;
  for (fs::directory_iterator it(out_dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (it->is_directory() && is_valid_date(name) && fs::exists(it->path() / "summary.json"))
      dates.push_back(name);
  }
  std::sort(dates.rbegin(), dates.rend());
  return dates;
}

// ------------------------------------------------------------------------------ all of it

ReportResult build_report(const ReportConfig& config, const ReportOptions& options) {
  ReportResult result;
  const auto t0 = Clock::now();
  try {
    std::string why;
    if (!options.IsValid(&why)) {
      result.error = why;
      return result;
    }
    const std::string date = options.date.empty() ? utc_today() : options.date;
    result.dir = options.out_dir / date;

    const auto t_run = Clock::now();
    result.runs = run_report_studies(config, options);
    result.run_s = seconds_since(t_run);
    for (const EntryRun& r : result.runs)
      if (r.run.outcome != studies::RunOutcome::kCompleted) {
        result.error = "entry " + r.entry_id + " (study " + r.study_id + "): " +
                       to_string(r.run.outcome) + (r.run.error.empty() ? "" : ": " + r.run.error);
        return result;
      }

    store::Store store = store::Store::open(options.db, store::Store::Mode::kReadOnly);
    json summary = make_summary(store, config, result.runs, date);
    json previous;
    const auto prev_path = find_previous_summary(options.out_dir, date);
    if (prev_path) {
      const auto text = read_file(*prev_path);
      std::vector<common::SpecError> errs;
      auto parsed = text ? common::parse_json(*text, &errs) : std::nullopt;
      if (!parsed)
        throw std::runtime_error("cannot read the previous report's " + prev_path->string());
      previous = std::move(*parsed);
      result.previous_date = previous.value("date", "");
    }
    summary["changes"] =
        compare_summaries(prev_path ? &previous : nullptr, summary, config.map_tolerance);
    result.flagged = summary["changes"]["flagged"].get<std::size_t>();

    fs::create_directories(result.dir);
    const auto t_render = Clock::now();
    render_report_html(store, summary, result.dir, options.gnuplot);
    result.render_s = seconds_since(t_render);
    result.wall_s = seconds_since(t0);
    summary["timing"] = {{"run_s", result.run_s}, {"render_s", result.render_s}};
    result.summary = result.dir / "summary.json";
    {
      std::ofstream out(result.summary, std::ios::binary | std::ios::trunc);
      out << summary.dump(1) << "\n";
      if (!out.flush()) throw std::runtime_error("cannot write " + result.summary.string());
    }
    result.html = result.dir / "index.html";
    result.summary_json = std::move(summary);
    result.ok = true;
  } catch (const std::exception& e) {
    result.error = e.what();
  }
  result.wall_s = seconds_since(t0);
  return result;
}

}  // namespace stickslip::reports
