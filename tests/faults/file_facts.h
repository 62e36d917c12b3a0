#pragma once
// What a store file holds, read with a plain read-only SQLite connection (never through the
// store library, so that the checks do not share its code), and the checks every
// fault-injection case makes (docs/store.md, Guarantees):
//  - PRAGMA integrity_check is "ok" and PRAGMA foreign_key_check finds nothing;
//  - no duplicates: one study per idempotency key, one diagnosis per key, and each study's run
//    counters equal the count of its runs (a run is one row by its primary key);
//  - no partial run: every run has its stage metrics, and its trace when it was written with one.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace stickslip::testing {

/// A plain connection; every query returns its rows as text (NULL as "NULL"). Read-only, unless
/// the file needs a hot journal rolled back or its WAL index rebuilt (SQLITE_READONLY_ROLLBACK,
/// SQLITE_READONLY_RECOVERY: a writer failed or died mid-transaction), which only a read-write
/// connection may do, as the next writer would; recovered() tells. Nothing is written otherwise.
class RawDb {
 public:
  explicit RawDb(const std::filesystem::path& db) {
    open(db, SQLITE_OPEN_READONLY);
    sqlite3_stmt* st = nullptr;
    int rc = sqlite3_prepare_v2(h_, "SELECT count(*) FROM sqlite_master", -1, &st, nullptr);
    if (rc == SQLITE_OK) rc = sqlite3_step(st);
    sqlite3_finalize(st);
    if ((sqlite3_extended_errcode(h_) & 0xff) == SQLITE_READONLY && rc != SQLITE_ROW) {
      sqlite3_close_v2(h_);
      open(db, SQLITE_OPEN_READWRITE);
      recovered_ = true;
    }
  }
  ~RawDb() { sqlite3_close_v2(h_); }
  bool recovered() const noexcept { return recovered_; }
  RawDb(const RawDb&) = delete;
  RawDb& operator=(const RawDb&) = delete;

  /// Every row, each column as text; an SQL error throws naming the query.
  std::vector<std::vector<std::string>> rows(const std::string& sql) const {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(h_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      throw std::runtime_error(sql + ": " + sqlite3_errmsg(h_));
    std::vector<std::vector<std::string>> out;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
      std::vector<std::string> row;
      for (int c = 0; c < sqlite3_column_count(st); ++c) {
        const auto* t = sqlite3_column_text(st, c);
        row.emplace_back(t != nullptr ? reinterpret_cast<const char*>(t) : "NULL");
      }
      out.push_back(std::move(row));
    }
    const std::string err = rc == SQLITE_DONE ? "" : sqlite3_errmsg(h_);
    sqlite3_finalize(st);
    if (!err.empty()) throw std::runtime_error(sql + ": " + err);
    return out;
  }
  /// The first column of the first row ("<no row>" when there is none).
  std::string text(const std::string& sql) const {
    const auto r = rows(sql);
    return r.empty() || r[0].empty() ? "<no row>" : r[0][0];
  }
  std::int64_t integer(const std::string& sql) const { return std::stoll(text(sql)); }

 private:
  void open(const std::filesystem::path& db, int flags) {
    h_ = nullptr;
    if (sqlite3_open_v2(db.c_str(), &h_, flags, nullptr) != SQLITE_OK) {
      const std::string msg = h_ != nullptr ? sqlite3_errmsg(h_) : "out of memory";
      sqlite3_close_v2(h_);
      throw std::runtime_error("cannot open " + db.string() + ": " + msg);
    }
    sqlite3_extended_result_codes(h_, 1);
    sqlite3_busy_timeout(h_, 10000);
  }

  sqlite3* h_ = nullptr;
  bool recovered_ = false;
};

inline std::string quoted(const std::string& s) {
  std::string out = "'";
  for (const char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

/// The design indices of a study's stored runs.
inline std::set<std::int64_t> stored_runs(const RawDb& db, const std::string& study) {
  std::set<std::int64_t> out;
  for (const auto& r : db.rows("SELECT design_index FROM runs WHERE study_id = " + quoted(study)))
    out.insert(std::stoll(r[0]));
  return out;
}

/// One line per stored run of a study with everything stored of it (the run's row without
/// `skip` columns, its stage metrics and its trace), keyed by design index: two files hold the
/// same runs exactly when these maps are equal.
inline std::map<std::int64_t, std::string> run_contents(const RawDb& db, const std::string& study,
                                                        bool with_times) {
  const std::string times = with_times ? "quote(wall_time_s) || quote(finished_at) || " : "";
  std::map<std::int64_t, std::string> out;
  const std::string q = quoted(study);
  for (const auto& r : db.rows(
           "SELECT design_index, quote(param_hash) || quote(params_json) || quote(model) || "
           "quote(va_over_vd) || quote(status) || quote(error) || " + times +
           "quote(t_end) || quote(steps) || quote(rmse) FROM runs WHERE study_id = " + q))
    out[std::stoll(r[0])] = r[1];
  for (const auto& r : db.rows(
           "SELECT design_index, group_concat(stage || ':' || quote(t_start) || quote(t_end) || "
           "quote(amplitude) || quote(amplitude_raw) || quote(mean_force) || "
           "quote(mean_friction) || slip_events || quote(mean_period) || quote(rmse), ';') "
           "FROM (SELECT * FROM stage_metrics WHERE study_id = " + q +
           " ORDER BY design_index, stage) GROUP BY design_index"))
    out[std::stoll(r[0])] += " stages " + r[1];
  for (const auto& r : db.rows(
           "SELECT design_index, n_samples || ':' || hex(t) || hex(F_d) || hex(F_f) || hex(x) || "
           "hex(v) || hex(s) FROM traces WHERE study_id = " + q))
    out[std::stoll(r[0])] += " trace " + r[1];
  return out;
}

/// The checks every case makes on a file after a fault (see the header comment). label names
/// the case in failure messages.
inline void expect_sound_file(const std::filesystem::path& path, const std::string& label) {
  SCOPED_TRACE(label);
  RawDb db(path);
  EXPECT_EQ(db.text("PRAGMA integrity_check"), "ok");
  EXPECT_EQ(db.rows("PRAGMA foreign_key_check").size(), 0u);
  if (db.integer("SELECT count(*) FROM sqlite_master WHERE name = 'studies'") == 0) return;
  EXPECT_EQ(db.integer("SELECT count(*) FROM (SELECT idempotency_key FROM studies WHERE "
                       "idempotency_key IS NOT NULL GROUP BY idempotency_key HAVING count(*) > 1)"),
            0)
      << "a study key is stored twice";
  EXPECT_EQ(db.integer("SELECT count(*) FROM (SELECT idempotency_key FROM diagnoses WHERE "
                       "idempotency_key IS NOT NULL GROUP BY idempotency_key HAVING count(*) > 1)"),
            0)
      << "a diagnosis key is stored twice";
  EXPECT_EQ(db.integer("SELECT count(*) FROM studies AS s WHERE runs_done <> (SELECT count(*) "
                       "FROM runs AS r WHERE r.study_id = s.id)"),
            0)
      << "a study's run counter differs from its runs";
  EXPECT_EQ(db.integer("SELECT count(*) FROM runs AS r WHERE NOT EXISTS (SELECT 1 FROM "
                       "stage_metrics AS m WHERE m.study_id = r.study_id AND m.design_index = "
                       "r.design_index) AND r.status = 'ok'"),
            0)
      << "an ok run without its stage metrics (a partial run)";
}

/// An integer from the environment (the long suites' switches), or fallback.
inline long env_long(const char* name, long fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::strtol(v, nullptr, 10) : fallback;
}

/// STICKSLIP_FAULTS_LONG=1: the long fault-injection suite (docs/store.md, Guarantees).
inline bool long_faults() { return env_long("STICKSLIP_FAULTS_LONG", 0) != 0; }

}  // namespace stickslip::testing
