// Result handlers: GET /v1/studies/{id}/runs and GET /v1/studies/{id}/map, JSON or CSV.
// The formats are those of the local CLI (studies/export.h for runs, studies/map.h for maps),
// so `stickslip study export` / `stickslip map --db` and the server agree column for column.
#include <charconv>

#include "api_util.h"
#include "stickslip/server/api.h"
#include "stickslip/studies/export.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/studies/map.h"

namespace stickslip::server {

using detail::Format;
using detail::store_failure;
using detail::unknown_study;
using nlohmann::json;
using store::RunRecord;
using store::StoreError;

namespace {

constexpr std::size_t kReadChunk = 1000;

std::optional<std::int64_t> runs_token(const std::string& s) {
  std::int64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || v < 0) return std::nullopt;
  return v;
}

/// Number of stages of a stored spec (the canonical spec lists them all).
std::size_t stage_count(const std::string& spec_json) {
  std::vector<common::SpecError> ignored;
  const auto spec = common::parse_json(spec_json, &ignored);
  if (!spec || !spec->contains("stages") || !(*spec)["stages"].is_array()) return 2;
  return (*spec)["stages"].size();
}

}  // namespace

Response Api::get_runs(const Request& r, const std::string& id) const {
  const auto format = detail::negotiate(r, true);
  if (!format) return detail::not_acceptable(r, true);
  const auto q = r.query();
  // JSON is always paged; CSV is the whole table unless a page is asked for.
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
    const auto rec = store->get_study(id);
    if (!rec) return unknown_study(id, r.path());
    if (*format == Format::kCsv) {
      const std::size_t stages = stage_count(rec->spec_json);
      std::string csv;
      std::vector<std::string> names;
      bool more = false;
      std::vector<RunRecord> runs;
      if (paged) {
        runs = store->get_runs(id, after, *page_size + 1);
        more = runs.size() > *page_size;
        if (more) runs.pop_back();
        if (!runs.empty()) names = studies::param_names_of(runs.front());
        csv = studies::runs_csv_header(names, stages) + studies::runs_csv_rows(runs, names, stages);
      } else {
        // The whole table, read in chunks so a large study is never held twice.
        bool first = true;
        while (true) {
          auto chunk = store->get_runs(id, after, kReadChunk);
          if (chunk.empty()) break;
          if (first) {
            names = studies::param_names_of(chunk.front());
            csv = studies::runs_csv_header(names, stages);
            first = false;
          }
          csv += studies::runs_csv_rows(chunk, names, stages);
          after = chunk.back().design_index;
        }
        if (first) csv = studies::runs_csv_header({}, stages);
      }
      Response resp = text_response(200, "text/csv; charset=utf-8", std::move(csv));
      if (more) resp.set_header("Next-Page-Token", std::to_string(runs.back().design_index));
      return resp;
    }
    auto runs = store->get_runs(id, after, *page_size + 1);
    const bool more = runs.size() > *page_size;
    if (more) runs.pop_back();
    json out = {{"study_id", id},
                {"runs", json::array()},
                {"next_page_token",
                 more ? json(std::to_string(runs.back().design_index)) : json(nullptr)}};
    for (const auto& run : runs) out["runs"].push_back(studies::run_to_json(run));
    return json_response(200, out);
  } catch (const StoreError& e) {
    return store_failure(e, r.path());
  }
}

Response Api::get_map(const Request& r, const std::string& id) const {
  const auto format = detail::negotiate(r, true);
  if (!format) return detail::not_acceptable(r, true);
  // layout=columns: the same map by columns (studies::map_to_columns_json), for large maps.
  const auto q = r.query();
  const auto layout = q.find("layout");
  const bool columns = layout != q.end() && layout->second == "columns";
  if (layout != q.end() && !columns && layout->second != "rows")
    return problem(400, "invalid-parameter", "Invalid query parameter",
                   "layout must be rows or columns, got \"" + layout->second + "\"",
                   {FieldError::query("layout", "expected rows or columns")}, r.path());
  try {
    auto store = pool_.acquire();
    if (!store->get_study(id)) return unknown_study(id, r.path());
    studies::StudyMap map;
    try {
      map = studies::build_map(*store, id);
    } catch (const std::invalid_argument& e) {
      return problem(409, "spec-unreadable", "Stored spec unreadable", e.what(), {}, r.path());
    }
    if (*format == Format::kCsv)
      return text_response(200, "text/csv; charset=utf-8", studies::map_to_csv(map));
    return json_response(200, columns ? studies::map_to_columns_json(map) : studies::map_to_json(map));
  } catch (const StoreError& e) {
    return store_failure(e, r.path());
  }
}

}  // namespace stickslip::server
