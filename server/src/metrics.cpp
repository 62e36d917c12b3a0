// GET /metrics: Prometheus text exposition format 0.0.4.
//
// Study and run figures are read from the store itself on every scrape, so they are exact and
// survive restarts (runs are never deleted, so the run counters are monotonic as Prometheus
// counters must be). The Store API has no aggregate queries, so this file runs four read-only
// aggregate queries against the documented schema (docs/store.md) on its own connection.
#include <sqlite3.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "api_util.h"
#include "stickslip/server/api.h"

namespace stickslip::server {
namespace {

/// Upper bounds of stickslip_run_duration_seconds [s].
constexpr std::array<double, 12> kBuckets = {0.01, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 300};

struct StoreFigures {
  std::map<std::string, long long> studies;  // state -> count
  std::map<std::string, long long> diagnoses;  // state -> count
  std::map<std::string, long long> runs;     // status -> count
  std::array<long long, kBuckets.size()> le{};
  long long count = 0;
  double sum = 0;
};

class ReadOnlyDb {
 public:
  explicit ReadOnlyDb(const std::string& path) {
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      const std::string msg = db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close_v2(db_);
      db_ = nullptr;
      throw store::StoreError(path + ": cannot open for metrics: " + msg);
    }
    sqlite3_busy_timeout(db_, 2000);
  }
  ~ReadOnlyDb() { sqlite3_close_v2(db_); }
  ReadOnlyDb(const ReadOnlyDb&) = delete;
  ReadOnlyDb& operator=(const ReadOnlyDb&) = delete;

  template <class Row>
  void each(const std::string& sql, Row row) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      throw store::StoreError(std::string("metrics query failed: ") + sqlite3_errmsg(db_));
    int rc = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) row(st);
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE)
      throw store::StoreError(std::string("metrics query failed: ") + sqlite3_errmsg(db_));
  }

 private:
  sqlite3* db_ = nullptr;
};

std::string text(sqlite3_stmt* st, int col) {
  const auto* t = reinterpret_cast<const char*>(sqlite3_column_text(st, col));
  return t != nullptr ? t : "";
}

StoreFigures read_figures(const std::string& path) {
  ReadOnlyDb db(path);
  StoreFigures f;
  for (const char* s : {"queued", "running", "succeeded", "failed", "cancelled"})
    f.studies[s] = f.diagnoses[s] = 0;
  for (const char* s : {"ok", "diverged", "invalid"}) f.runs[s] = 0;
  db.each("SELECT state, count(*) FROM studies GROUP BY state", [&](sqlite3_stmt* st) {
    f.studies[text(st, 0)] = sqlite3_column_int64(st, 1);
  });
  db.each("SELECT state, count(*) FROM diagnoses GROUP BY state", [&](sqlite3_stmt* st) {
    f.diagnoses[text(st, 0)] = sqlite3_column_int64(st, 1);
  });
  db.each("SELECT status, count(*) FROM runs GROUP BY status", [&](sqlite3_stmt* st) {
    f.runs[text(st, 0)] = sqlite3_column_int64(st, 1);
  });
  std::string sql = "SELECT count(*), total(wall_time_s)";
  char buf[64];
  for (const double b : kBuckets) {
    std::snprintf(buf, sizeof buf, ", total(wall_time_s <= %.17g)", b);
    sql += buf;
  }
  sql += " FROM runs";
  db.each(sql, [&](sqlite3_stmt* st) {
    f.count = sqlite3_column_int64(st, 0);
    f.sum = sqlite3_column_double(st, 1);
    for (std::size_t i = 0; i < kBuckets.size(); ++i)
      f.le[i] = static_cast<long long>(sqlite3_column_double(st, static_cast<int>(i) + 2));
  });
  return f;
}

}  // namespace

namespace detail {
std::string shortest_number(double v) {
  char buf[40];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}
}  // namespace detail

namespace {
std::string number(double v) { return detail::shortest_number(v); }

}  // namespace

Response Api::metrics(const Request& r) const {
  StoreFigures f;
  try {
    f = read_figures(options_.db.string());
  } catch (const store::StoreError& e) {
    return detail::store_failure(e, r.path());
  }
  std::string out;
  out += "# HELP stickslip_runs_total Runs stored, by status (ok, diverged, invalid).\n";
  out += "# TYPE stickslip_runs_total counter\n";
  for (const auto& [status, n] : f.runs)
    out += "stickslip_runs_total{status=\"" + status + "\"} " + std::to_string(n) + "\n";
  out += "# HELP stickslip_run_duration_seconds Wall time of one stored run.\n";
  out += "# TYPE stickslip_run_duration_seconds histogram\n";
  for (std::size_t i = 0; i < kBuckets.size(); ++i)
    out += "stickslip_run_duration_seconds_bucket{le=\"" + number(kBuckets[i]) + "\"} " +
           std::to_string(f.le[i]) + "\n";
  out += "stickslip_run_duration_seconds_bucket{le=\"+Inf\"} " + std::to_string(f.count) + "\n";
  out += "stickslip_run_duration_seconds_sum " + number(f.sum) + "\n";
  out += "stickslip_run_duration_seconds_count " + std::to_string(f.count) + "\n";
  out += "# HELP stickslip_studies Studies in the store, by state.\n";
  out += "# TYPE stickslip_studies gauge\n";
  for (const auto& [state, n] : f.studies)
    out += "stickslip_studies{state=\"" + state + "\"} " + std::to_string(n) + "\n";
  out += "# HELP stickslip_queue_depth Studies waiting to run (state queued).\n";
  out += "# TYPE stickslip_queue_depth gauge\n";
  out += "stickslip_queue_depth " + std::to_string(f.studies["queued"]) + "\n";
  out += "# HELP stickslip_diagnoses Diagnoses in the store, by state.\n";
  out += "# TYPE stickslip_diagnoses gauge\n";
  for (const auto& [state, n] : f.diagnoses)
    out += "stickslip_diagnoses{state=\"" + state + "\"} " + std::to_string(n) + "\n";
  out += "# HELP stickslip_http_responses_total HTTP responses since start, by status class.\n";
  out += "# TYPE stickslip_http_responses_total counter\n";
  for (int c = 1; c <= 5; ++c)
    out += "stickslip_http_responses_total{class=\"" + std::to_string(c) + "xx\"} " +
           std::to_string(responses(c)) + "\n";
  return text_response(200, "text/plain; version=0.0.4; charset=utf-8", std::move(out));
}

}  // namespace stickslip::server
