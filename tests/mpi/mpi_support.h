#pragma once
// Shared by the MPI tests: mpirun command lines for this machine, study specs, and the stored
// results of two stores compared row by row with SQL (ATTACH + EXCEPT compares REALs and BLOBs
// exactly, so "no row differs" means bit for bit).
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "server/process.h"
#include "support/temp_dir.h"

namespace stickslip::mpitest {

namespace fs = std::filesystem;
using server::testing::CommandResult;
using server::testing::run_command;
using server::testing::slurp;

inline const std::string kClient = std::string(STICKSLIP_BINARY_DIR) + "/client/stickslip";
inline const std::string kServer = std::string(STICKSLIP_BINARY_DIR) + "/server/stickslipd";
inline const std::string kMpirun = STICKSLIP_MPIRUN;
inline const std::string kFaultLib = STICKSLIP_FAULT_MPI_LIB;

/// What Open MPI needs on this machine, for the processes these tests start only (never in a
/// user's environment): CI runs as root, which mpirun refuses unless told twice, and a
/// container may forbid the cross-memory attach of the shared-memory transport.
inline const bool kOpenMpiTestEnvironment = [] {
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  ::setenv("OMPI_MCA_btl_vader_single_copy_mechanism", "none", 1);
  return true;
}();

/// mpirun for np ranks on this 2-core machine (oversubscribed; unbound, so that a rank's
/// OpenMP threads may use both cores), with a fault (fault_rank_preload.cpp) when not empty.
inline std::vector<std::string> mpirun(int np, const std::string& fault = "") {
  std::vector<std::string> a = {kMpirun, "--oversubscribe", "--bind-to", "none", "-np",
                                std::to_string(np)};
  if (!fault.empty())
    a.insert(a.end(), {"-x", "LD_PRELOAD=" + kFaultLib, "-x", "STICKSLIP_MPI_FAULT=" + fault});
  return a;
}

/// The same as one --launcher string.
inline std::string launcher(int np, const std::string& fault = "") {
  std::string s;
  for (const std::string& w : mpirun(np, fault)) s += (s.empty() ? "" : " ") + w;
  return s;
}

/// argv + more.
inline std::vector<std::string> cat(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

inline fs::path write_file(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
  return p;
}

/// A grid of 2 models (karnopp, lugre) x n values of va_over_vd in [0, 4], 2.5 s + 1 s:
/// about 80 ms a run. extra: more top-level members, e.g. R"("integrator": {...})".
inline std::string grid_spec(const std::string& name, int n, const std::string& extra = "") {
  return R"({"name": ")" + name + R"(", "stages": [{"duration": 2.5}, {"duration": 1}],)" +
         (extra.empty() ? "" : extra + ",") +
         R"( "design": {"type": "grid", "axes": [{"name": "model", "values": ["karnopp", "lugre"]},
            {"name": "va_over_vd", "linspace": [0, 4, )" + std::to_string(n) + "]}]}}";
}

/// One SQL query on db (read-only); the first column of every row as text.
inline std::vector<std::string> query(const fs::path& db, const std::string& sql,
                                      const std::vector<fs::path>& attach = {}) {
  sqlite3* c = nullptr;
  if (sqlite3_open_v2(db.c_str(), &c, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK)
    throw std::runtime_error("cannot open " + db.string());
  std::string full;
  for (std::size_t i = 0; i < attach.size(); ++i)
    full += "ATTACH 'file:" + attach[i].string() + "?mode=ro' AS o" + std::to_string(i) + ";";
  std::vector<std::string> out;
  char* err = nullptr;
  if (!full.empty() && sqlite3_exec(c, full.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string e = err ? err : "?";
    sqlite3_free(err);
    sqlite3_close(c);
    throw std::runtime_error("attach: " + e);
  }
  sqlite3_stmt* st = nullptr;
  if (sqlite3_prepare_v2(c, sql.c_str(), -1, &st, nullptr) != SQLITE_OK) {
    const std::string e = sqlite3_errmsg(c);
    sqlite3_close(c);
    throw std::runtime_error(e + " in: " + sql);
  }
  while (sqlite3_step(st) == SQLITE_ROW) {
    const unsigned char* t = sqlite3_column_text(st, 0);
    out.emplace_back(t ? reinterpret_cast<const char*>(t) : "NULL");
  }
  sqlite3_finalize(st);
  sqlite3_close(c);
  return out;
}

inline std::int64_t query_int(const fs::path& db, const std::string& sql,
                              const std::vector<fs::path>& attach = {}) {
  const auto rows = query(db, sql, attach);
  return rows.empty() ? -1 : std::stoll(rows.front());
}

/// What a run computed, per table: every column but study_id, wall_time_s and finished_at.
inline const std::vector<std::pair<std::string, std::string>>& result_tables() {
  static const std::vector<std::pair<std::string, std::string>> t = {
      {"runs", "design_index, param_hash, params_json, model, va_over_vd, status, error, t_end, "
               "steps, rmse"},
      {"stage_metrics", "design_index, stage, t_start, t_end, amplitude, amplitude_raw, "
                        "mean_force, mean_friction, slip_events, mean_period, rmse"},
      {"traces", "design_index, n_samples, t, F_d, F_f, x, v, s"}};
  return t;
}

/// Result rows of a that b does not hold bit for bit (each store holds one study).
inline std::int64_t rows_missing(const fs::path& a, const fs::path& b) {
  std::int64_t n = 0;
  for (const auto& [table, cols] : result_tables())
    n += query_int(a, "SELECT count(*) FROM (SELECT " + cols + " FROM main." + table +
                          " EXCEPT SELECT " + cols + " FROM o0." + table + ")",
                   {b});
  return n;
}

/// Result rows of the store, over the three tables.
inline std::int64_t result_rows(const fs::path& db) {
  std::int64_t n = 0;
  for (const auto& [table, cols] : result_tables())
    n += query_int(db, "SELECT count(*) FROM " + table);
  return n;
}

/// Both stores hold the same results, row by row and bit for bit.
inline void expect_same_results(const fs::path& a, const fs::path& b) {
  ASSERT_GT(result_rows(a), 0);
  EXPECT_EQ(result_rows(a), result_rows(b)) << a << " vs " << b;
  EXPECT_EQ(rows_missing(a, b), 0) << "rows of " << a << " not in " << b;
  EXPECT_EQ(rows_missing(b, a), 0) << "rows of " << b << " not in " << a;
}

/// The one study of the store: state and error.
inline std::string state_of(const fs::path& db) { return query(db, "SELECT state FROM jobs")[0]; }
inline std::string error_of(const fs::path& db) { return query(db, "SELECT error FROM jobs")[0]; }
inline std::string integrity(const fs::path& db) {
  return query(db, "PRAGMA integrity_check")[0];
}
/// A consistent copy of a store (VACUUM INTO), to compare with later.
inline void snapshot(const fs::path& db, const fs::path& copy) {
  sqlite3* c = nullptr;
  sqlite3_open_v2(db.c_str(), &c, SQLITE_OPEN_READONLY, nullptr);
  const std::string sql = "VACUUM INTO '" + copy.string() + "'";
  char* err = nullptr;
  const int rc = sqlite3_exec(c, sql.c_str(), nullptr, nullptr, &err);
  sqlite3_close(c);
  if (rc != SQLITE_OK) throw std::runtime_error("snapshot: " + std::string(err ? err : "?"));
}

/// Exactly total runs, each design index once.
inline void expect_complete(const fs::path& db, std::int64_t total) {
  EXPECT_EQ(query_int(db, "SELECT count(*) FROM runs"), total);
  EXPECT_EQ(query_int(db, "SELECT count(DISTINCT design_index) FROM runs"), total);
  EXPECT_EQ(query_int(db, "SELECT min(design_index) FROM runs"), 0);
  EXPECT_EQ(query_int(db, "SELECT max(design_index) FROM runs"), total - 1);
  EXPECT_EQ(query_int(db, "SELECT progress_done FROM jobs"), total);
}

}  // namespace stickslip::mpitest
