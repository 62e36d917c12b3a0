#pragma once
// The nightly report (`stickslip report`, docs/report.md): runs or reuses the configured studies
// in a local store, then writes OUT/<date>/summary.json (every number the report shows, and what
// the next night compares against) and OUT/<date>/index.html (self-contained: gnuplot SVG plots
// embedded as data: URIs; copies of the plots are kept in OUT/<date>/plots/).
//
// Pipeline, each step a function that can be tested on its own:
//   parse_report_config  -> ReportConfig   (JSON Schema schemas/report.schema.json via valijson,
//                                           then every study spec parsed; all errors reported)
//   run_report_studies   -> per entry: study id, RunSummary (create_or_find_study reuses a study
//                                           with the same name and spec hash, run_study resumes)
//   make_summary         -> summary.json   (pure read of the store)
//   compare_summaries    -> "changes"      (pure: previous summary vs this one)
//   render_report_html   -> index.html     (runs gnuplot)
// build_report does all of it.
//
// Change detection ("changed since last night"), against the newest OUT/<date>/summary.json with
// an older date:
//   - an index (Sobol S1, ST; Morris mu_star) is flagged when its confidence interval and the
//     previous one do not overlap, i.e. the change exceeds both intervals' reach; an output that
//     became invalid (or valid) is flagged too;
//   - a map cell (entry, model, row key) is flagged when the amplitude of any stage moved by more
//     than map_tolerance.abs + map_tolerance.rel * |previous| [N], when its state changed (ok,
//     failed, missing), or when it appeared or disappeared;
//   - an entry whose study spec changed (other spec hash) is noted (not flagged by itself: its
//     cells and indices are compared like any other).

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/studies/indices.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/studies/runner.h"
#include "stickslip/studies/spec.h"

namespace stickslip::reports {

enum class EntryKind { kMap, kTraces, kIndices };
const char* to_string(EntryKind k) noexcept;

struct ReportEntry {
  std::string id, title;
  EntryKind kind = EntryKind::kMap;
  std::string spec_source;           ///< the path as written, or "(inline)"
  std::filesystem::path spec_dir;    ///< directory a relative measured path resolves against
  std::shared_ptr<const studies::StudySpec> spec;
  std::vector<std::string> outputs;  ///< indices only; empty = default_outputs
  std::string method;                ///< indices only; empty = the design's own
};

struct MapTolerance {
  double abs = 0.05;  ///< [N]
  double rel = 0.02;  ///< [-]
};

struct ReportConfig {
  std::string name, description;
  int threads = 0;
  MapTolerance map_tolerance;
  studies::IndicesOptions indices;
  std::vector<ReportEntry> entries;
  nlohmann::json document;  ///< the configuration as given (recorded in summary.json)
};

struct ReportConfigResult {
  std::optional<ReportConfig> config;  ///< set only when errors is empty
  std::vector<common::SpecError> errors;       ///< every problem, each with a JSON Pointer
  bool ok() const noexcept { return config.has_value(); }
};

/// Parses and validates a report configuration: malformed JSON, schema violations, duplicate
/// entry ids, unreadable spec files (pointer /studies/i/spec), errors inside a study spec
/// (pointer /studies/i/spec + the spec's own pointer, prefixed by the file name), an indices
/// entry whose design is not sobol/morris, a map entry whose design is not a grid, unknown
/// outputs. config_dir resolves relative spec paths.
ReportConfigResult parse_report_config(std::string_view text,
                                       const std::filesystem::path& config_dir);
/// The report schema embedded at build time (schemas/report.schema.json).
const nlohmann::json& report_schema();

struct ReportOptions {
  std::filesystem::path db;       ///< the local store (created if missing)
  std::filesystem::path out_dir;  ///< OUT
  std::string date;               ///< YYYY-MM-DD; empty = today (UTC)
  int threads = -1;               ///< < 0: the config's threads
  std::string gnuplot = "gnuplot";  ///< the gnuplot executable (PATH lookup)
  /// Called from the calling thread while studies run: entry id and progress.
  std::function<void(const std::string&, const studies::Progress&)> on_progress;
  /// Set and true: stop starting runs (the report is not written; the studies resume next time).
  const std::atomic<bool>* stop = nullptr;
  /// Where the studies are computed (studies/executor.h): OpenMP here by default, an MPI job
  /// per study with a launcher, or the ranks of the MPI job this process is rank 0 of.
  studies::Execution execution;
  bool IsValid(std::string* why) const;
};

struct EntryRun {
  std::string entry_id, study_id;
  studies::RunSummary run;
};

struct ReportResult {
  bool ok = false;
  std::string error;                 ///< why not ok
  std::filesystem::path dir, html, summary;
  std::optional<std::string> previous_date;  ///< the report compared against
  std::size_t flagged = 0;           ///< changes flagged
  std::vector<EntryRun> runs;
  double wall_s = 0.0, run_s = 0.0, render_s = 0.0;  ///< [s]
  nlohmann::json summary_json;
};

/// Runs (or resumes, or reuses) every entry's study in options.db.
std::vector<EntryRun> run_report_studies(const ReportConfig& config, const ReportOptions& options);

/// summary.json without "changes": {"report", "date", "generated_at", "db", "config",
/// "map_tolerance", "entries": {id: {"kind", "title", "study_id", "study_name", "spec_hash",
/// "state", "counts": {"total", "ok", "failed", "missing"}, "run": {...}, "map" | "indices" |
/// "traces": ...}}, "failures": {"total", "by_entry": {id: n}}}.
nlohmann::json make_summary(store::Store& store, const ReportConfig& config,
                            const std::vector<EntryRun>& runs, const std::string& date);

/// The "changes" object: {"previous_date", "flagged", "indices": [...], "map_cells": [...],
/// "notes": [...]}; previous null gives no changes.
nlohmann::json compare_summaries(const nlohmann::json* previous, const nlohmann::json& current,
                                 const MapTolerance& tolerance);

/// The newest OUT/<date>/summary.json whose date sorts before 'date' (YYYY-MM-DD directories
/// only); nullopt when there is none.
std::optional<std::filesystem::path> find_previous_summary(const std::filesystem::path& out_dir,
                                                           const std::string& date);

/// Dates (YYYY-MM-DD directories holding a summary.json) of the reports in out_dir, newest
/// first: what a server lists at GET /v1/reports (each served from out_dir/<date>/index.html).
std::vector<std::string> list_report_dates(const std::filesystem::path& out_dir);

/// Writes dir/index.html and dir/plots/*.svg from a summary (with its "changes") and the store
/// (traces). Throws std::runtime_error when gnuplot fails (its stderr in the message).
void render_report_html(store::Store& store, const nlohmann::json& summary,
                        const std::filesystem::path& dir, const std::string& gnuplot);

/// The whole report. Never throws: failures end up in ReportResult::error.
ReportResult build_report(const ReportConfig& config, const ReportOptions& options);

/// True for a real calendar date written YYYY-MM-DD.
bool is_valid_date(std::string_view date);
/// Today's date (UTC) as YYYY-MM-DD.
std::string utc_today();

}  // namespace stickslip::reports
