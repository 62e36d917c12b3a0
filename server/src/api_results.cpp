// Result handlers: GET /v1/studies/{id}/runs and GET /v1/studies/{id}/map (JSON or CSV).
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "api_util.h"
#include "stickslip/server/api.h"
#include "stickslip/studies/json_schema.h"

namespace stickslip::server {

using detail::csv_number;
using detail::csv_text;
using detail::Format;
using detail::number_or_null;
using detail::store_failure;
using detail::unknown_study;
using nlohmann::json;
using studies::RunRecord;
using studies::StoreError;

namespace {

constexpr std::size_t kReadChunk = 1000;

json run_json(const RunRecord& run) {
  std::vector<studies::SpecError> ignored;
  auto params = studies::parse_json(run.params_json, &ignored);
  json stages = json::array();
  for (const auto& s : run.stages) {
    stages.push_back({{"stage", s.stage},
                      {"t_start", number_or_null(s.t_start)},
                      {"t_end", number_or_null(s.t_end)},
                      {"amplitude", number_or_null(s.amplitude)},
                      {"amplitude_raw", number_or_null(s.amplitude_raw)},
                      {"mean_force", number_or_null(s.mean_force)},
                      {"mean_friction", number_or_null(s.mean_friction)},
                      {"slip_events", s.slip_events},
                      {"mean_period", number_or_null(s.mean_period)},
                      {"rmse", s.rmse ? number_or_null(*s.rmse) : json(nullptr)}});
  }
  return {{"design_index", run.design_index},
          {"status", run.status},
          {"error", run.error.empty() ? json(nullptr) : json(run.error)},
          {"model", run.model ? json(*run.model) : json(nullptr)},
          {"va_over_vd", run.va_over_vd ? number_or_null(*run.va_over_vd) : json(nullptr)},
          {"params", params ? std::move(*params) : json::object()},
          {"param_hash", run.param_hash},
          {"wall_time_s", number_or_null(run.wall_time_s)},
          {"t_end", number_or_null(run.t_end)},
          {"steps", run.steps},
          {"rmse", run.rmse ? number_or_null(*run.rmse) : json(nullptr)},
          {"finished_at", run.finished_at},
          {"stages", std::move(stages)}};
}

constexpr const char* kRunsCsvHeader =
    "design_index,model,va_over_vd,status,error,wall_time_s,t_end,steps,rmse,stage,stage_t_start,"
    "stage_t_end,amplitude,amplitude_raw,mean_force,mean_friction,slip_events,mean_period,"
    "stage_rmse,params_json\n";

/// One CSV row per run and stage; a run without stages (e.g. invalid) gets one row with the
/// stage columns empty, so failures are never dropped.
void append_run_csv(std::string& out, const RunRecord& run) {
  std::string prefix = std::to_string(run.design_index) + "," + csv_text(run.model.value_or("")) +
                       "," + (run.va_over_vd ? csv_number(*run.va_over_vd) : "") + "," +
                       run.status + "," + csv_text(run.error) + "," + csv_number(run.wall_time_s) +
                       "," + csv_number(run.t_end) + "," + std::to_string(run.steps) + "," +
                       (run.rmse ? csv_number(*run.rmse) : "") + ",";
  const std::string suffix = "," + csv_text(run.params_json) + "\n";
  if (run.stages.empty()) {
    out += prefix + ",,,,,,,,,," + suffix.substr(1);
    return;
  }
  for (const auto& s : run.stages) {
    out += prefix + std::to_string(s.stage) + "," + csv_number(s.t_start) + "," +
           csv_number(s.t_end) + "," + csv_number(s.amplitude) + "," +
           csv_number(s.amplitude_raw) + "," + csv_number(s.mean_force) + "," +
           csv_number(s.mean_friction) + "," + std::to_string(s.slip_events) + "," +
           csv_number(s.mean_period) + "," + (s.rmse ? csv_number(*s.rmse) : "") + suffix;
  }
}

std::optional<std::int64_t> runs_token(const std::string& s) {
  std::int64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || v < 0) return std::nullopt;
  return v;
}

}  // namespace

Response Api::get_runs(const Request& r, const std::string& id) const {
  const auto format = detail::negotiate(r, true);
  if (!format) return detail::not_acceptable(r, true);
  const auto q = r.query();
  const bool paged = *format == Format::kJson || q.count("page_size") > 0 || q.count("page_token");
  Response error;
  const auto page_size =
      detail::page_size_param(r, options_.default_runs_page_size, options_.max_page_size, &error);
  if (!page_size) return error;
  std::int64_t after = -1;
  if (const auto t = q.find("page_token"); t != q.end()) {
    const auto v = runs_token(t->second);
    if (!v) {
      return problem(400, "invalid-parameter", "Invalid query parameter",
                     "page_token is not a token returned by this endpoint",
                     {FieldError::query("page_token", "not a token from next_page_token")},
                     r.path());
    }
    after = *v;
  }
  try {
    auto store = pool_.acquire();
    if (!store->get_study(id)) return unknown_study(id, r.path());
    std::vector<RunRecord> runs;
    bool more = false;
    if (paged) {
      runs = store->get_runs(id, after, *page_size + 1);
      more = runs.size() > *page_size;
      if (more) runs.pop_back();
    } else {
      // The whole table: read in chunks so a large study never holds two copies.
      std::string csv = kRunsCsvHeader;
      while (true) {
        auto chunk = store->get_runs(id, after, kReadChunk);
        if (chunk.empty()) break;
        for (const auto& run : chunk) append_run_csv(csv, run);
        after = chunk.back().design_index;
      }
      return text_response(200, "text/csv; charset=utf-8", std::move(csv));
    }
    const json next = more ? json(std::to_string(runs.back().design_index)) : json(nullptr);
    if (*format == Format::kCsv) {
      std::string csv = kRunsCsvHeader;
      for (const auto& run : runs) append_run_csv(csv, run);
      Response resp = text_response(200, "text/csv; charset=utf-8", std::move(csv));
      if (more) resp.set_header("Next-Page-Token", next.get<std::string>());
      return resp;
    }
    json out = {{"study_id", id}, {"runs", json::array()}, {"next_page_token", next}};
    for (const auto& run : runs) out["runs"].push_back(run_json(run));
    return json_response(200, out);
  } catch (const StoreError& e) {
    return store_failure(e, r.path());
  }
}

Response Api::get_map(const Request& r, const std::string& id) const {
  const auto format = detail::negotiate(r, true);
  if (!format) return detail::not_acceptable(r, true);
  try {
    auto store = pool_.acquire();
    const auto rec = store->get_study(id);
    if (!rec) return unknown_study(id, r.path());
    // Every design point is a map cell, stored or not: missing and failed cells are marked.
    studies::Limits unlimited;
    unlimited.max_runs = std::numeric_limits<std::size_t>::max();
    auto parsed = studies::parse_study(rec->spec_json, unlimited);
    if (!parsed.ok()) {
      return problem(409, "spec-unreadable", "Stored spec unreadable",
                     "the stored spec of study " + id +
                         " no longer parses: " + studies::to_string(parsed.errors),
                     {}, r.path());
    }
    const auto& spec = *parsed.spec;
    const std::size_t n_stages = spec.canonical().contains("stages")
                                     ? spec.canonical()["stages"].size()
                                     : std::size_t{2};
    std::map<std::int64_t, RunRecord> stored;
    for (std::int64_t after = -1;;) {
      auto chunk = store->get_runs(id, after, kReadChunk);
      if (chunk.empty()) break;
      after = chunk.back().design_index;
      for (auto& run : chunk) stored.emplace(run.design_index, std::move(run));
    }
    const double nan = std::numeric_limits<double>::quiet_NaN();
    json points = json::array();
    std::string csv = "design_index,model,va_over_vd,status";
    for (std::size_t s = 1; s <= n_stages; ++s) csv += ",amplitude_" + std::to_string(s);
    for (std::size_t s = 1; s <= n_stages; ++s) csv += ",mean_force_" + std::to_string(s);
    csv += ",reduction_ratio,error\n";
    std::vector<std::string> models;
    std::set<double> ratios;
    for (std::size_t i = 0; i < spec.run_count(); ++i) {
      const auto p = spec.point(i);
      if (std::find(models.begin(), models.end(), p.model) == models.end())
        models.push_back(p.model);
      const auto va = p.value("va_over_vd");
      if (va) ratios.insert(*va);
      std::vector<double> amplitude(n_stages, nan), mean_force(n_stages, nan);
      std::string status = "missing", error;
      if (const auto it = stored.find(static_cast<std::int64_t>(i)); it != stored.end()) {
        status = it->second.status;
        error = it->second.error;
        for (const auto& st : it->second.stages) {
          if (st.stage < 1 || static_cast<std::size_t>(st.stage) > n_stages) continue;
          amplitude[static_cast<std::size_t>(st.stage) - 1] = st.amplitude;
          mean_force[static_cast<std::size_t>(st.stage) - 1] = st.mean_force;
        }
      }
      // Reduction ratio: amplitude of the last stage over the first (the seed's stage 2 / 1).
      double ratio = nan;
      if (n_stages >= 2 && std::isfinite(amplitude.front()) && amplitude.front() > 0 &&
          std::isfinite(amplitude.back()))
        ratio = amplitude.back() / amplitude.front();
      json a = json::array(), f = json::array();
      for (std::size_t s = 0; s < n_stages; ++s) {
        a.push_back(number_or_null(amplitude[s]));
        f.push_back(number_or_null(mean_force[s]));
      }
      points.push_back({{"design_index", i},
                        {"model", p.model},
                        {"va_over_vd", va ? number_or_null(*va) : json(nullptr)},
                        {"status", status},
                        {"amplitude", std::move(a)},
                        {"mean_force", std::move(f)},
                        {"reduction_ratio", number_or_null(ratio)},
                        {"error", error.empty() ? json(nullptr) : json(error)}});
      csv += std::to_string(i) + "," + csv_text(p.model) + "," + (va ? csv_number(*va) : "") +
             "," + status;
      for (const double v : amplitude) csv += "," + csv_number(v);
      for (const double v : mean_force) csv += "," + csv_number(v);
      csv += "," + csv_number(ratio) + "," + csv_text(error) + "\n";
    }
    if (*format == Format::kCsv) return text_response(200, "text/csv; charset=utf-8", std::move(csv));
    json out = {{"study_id", id},
                {"state", studies::to_string(rec->state)},
                {"stages", n_stages},
                {"models", models},
                {"va_over_vd", json(std::vector<double>(ratios.begin(), ratios.end()))},
                {"units", {{"amplitude", "N"}, {"mean_force", "N"}, {"va_over_vd", "1"}}},
                {"points", std::move(points)}};
    return json_response(200, out);
  } catch (const StoreError& e) {
    return store_failure(e, r.path());
  }
}

}  // namespace stickslip::server
