#pragma once
// What the store's tests share (test_store*.cpp): a raw SQLite handle to inspect and damage
// files, random and simple records, exact comparisons, and the StoreTest fixture.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "stickslip/store/store.h"
#include "support/temp_dir.h"

namespace stickslip::store::test_support {

namespace fs = std::filesystem;
using stickslip::store::CreatedStudy;
using stickslip::store::FlushResult;
using stickslip::store::NewStudy;
using stickslip::store::RunRecord;
using stickslip::store::RunWriter;
using stickslip::store::StageMetricsRecord;
using stickslip::store::Store;
using stickslip::store::StoreError;
using stickslip::store::StudyState;
using stickslip::store::TracePoint;
using stickslip::store::WriterOptions;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// A direct sqlite3 connection, independent of the code under test.
class RawDb {
 public:
  explicit RawDb(const fs::path& path, int flags = SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE) {
    if (sqlite3_open_v2(path.c_str(), &db_, flags, nullptr) != SQLITE_OK)
      throw std::runtime_error("RawDb open: " + std::string(sqlite3_errmsg(db_)));
    sqlite3_busy_timeout(db_, 100);
  }
  RawDb(const RawDb&) = delete;
  RawDb& operator=(const RawDb&) = delete;
  ~RawDb() { sqlite3_close_v2(db_); }

  void exec(const std::string& sql) {
    char* err = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
      std::string msg = err != nullptr ? err : "?";
      sqlite3_free(err);
      throw std::runtime_error("RawDb exec '" + sql + "': " + msg);
    }
  }
  /// All rows of a query, every value as text (NULL as "NULL").
  std::vector<std::vector<std::string>> rows(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      throw std::runtime_error("RawDb prepare '" + sql + "': " + sqlite3_errmsg(db_));
    std::vector<std::vector<std::string>> out;
    int rc = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
      std::vector<std::string> row;
      for (int c = 0; c < sqlite3_column_count(st); ++c) {
        const auto* t = reinterpret_cast<const char*>(sqlite3_column_text(st, c));
        row.emplace_back(t != nullptr ? t : "NULL");
      }
      out.push_back(std::move(row));
    }
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE) throw std::runtime_error("RawDb step '" + sql + "': " + sqlite3_errmsg(db_));
    return out;
  }
  std::int64_t integer(const std::string& sql) { return std::stoll(rows(sql).at(0).at(0)); }
  std::string text(const std::string& sql) { return rows(sql).at(0).at(0); }
  /// A REAL value exactly as stored (sqlite3_column_double).
  double real(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr);
    if (sqlite3_step(st) != SQLITE_ROW) {
      sqlite3_finalize(st);
      throw std::runtime_error("RawDb real: no row for " + sql);
    }
    const double v = sqlite3_column_double(st, 0);
    sqlite3_finalize(st);
    return v;
  }

 private:
  sqlite3* db_ = nullptr;
};

inline std::string file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline std::uint64_t bits(double d) { return std::bit_cast<std::uint64_t>(d); }

#define EXPECT_SAME_DOUBLE(a, b) EXPECT_EQ(bits(a), bits(b)) << (a) << " vs " << (b)

inline void expect_same_opt(const std::optional<double>& a, const std::optional<double>& b) {
  ASSERT_EQ(a.has_value(), b.has_value());
  if (a) {
    EXPECT_SAME_DOUBLE(*a, *b);
  }
}

/// Any double except NaN (stored as NULL) and -0.0 (read back as +0.0; see store.h).
inline double random_double(std::mt19937_64& rng) {
  for (;;) {
    const double d = std::bit_cast<double>(rng());
    if (!std::isnan(d) && !(d == 0.0 && std::signbit(d))) return d;
  }
}

inline double pick_double(std::mt19937_64& rng) {
  static constexpr double kSpecial[] = {0.0,
                                        1.0,
                                        0.1,
                                        1e-300,
                                        std::numeric_limits<double>::denorm_min(),
                                        std::numeric_limits<double>::max(),
                                        std::numeric_limits<double>::lowest(),
                                        std::numeric_limits<double>::infinity(),
                                        -std::numeric_limits<double>::infinity(),
                                        4611686018427387904.0 /* 2^62, stored as integer */};
  const auto k = rng() % 32;
  return k < std::size(kSpecial) ? kSpecial[k] : random_double(rng);
}

inline StageMetricsRecord random_stage(std::mt19937_64& rng, int stage) {
  StageMetricsRecord m;
  m.stage = stage;
  m.t_start = pick_double(rng);
  m.t_end = pick_double(rng);
  m.amplitude = pick_double(rng);
  m.amplitude_raw = pick_double(rng);
  m.mean_force = pick_double(rng);
  m.mean_friction = pick_double(rng);
  m.slip_events = static_cast<std::int64_t>(rng() % 100000);
  m.mean_period = pick_double(rng);
  if (rng() % 2 == 0) m.rmse = pick_double(rng);
  return m;
}

inline std::vector<TracePoint> random_trace(std::mt19937_64& rng, std::size_t n) {
  std::vector<TracePoint> trace(n);
  for (auto& p : trace)
    p = {pick_double(rng), pick_double(rng), pick_double(rng), pick_double(rng), pick_double(rng),
         pick_double(rng)};
  return trace;
}

/// Run i of the 1000-run study: every 7th from 3 is invalid (no stages), every 7th from 5
/// diverged (1 stage), the rest ok (2 stages); two models; va_over_vd NULL for i % 11 == 0.
inline RunRecord random_run(const std::string& study, std::int64_t i, std::mt19937_64& rng) {
  RunRecord r;
  r.study_id = study;
  r.design_index = i;
  r.model = i % 2 == 0 ? "lugre" : "dieterich";
  if (i % 11 != 0) r.va_over_vd = pick_double(rng);
  r.params_json = R"({"model":")" + *r.model + R"(","k":)" + std::to_string(i) + "}";
  r.param_hash = stickslip::store::param_hash(r.params_json);
  const int kind = static_cast<int>(i % 7);
  r.status = kind == 3 ? "invalid" : kind == 5 ? "diverged" : "ok";
  if (r.status != "ok") r.error = "reason " + std::to_string(i);
  const int n_stages = kind == 3 ? 0 : kind == 5 ? 1 : 2;
  for (int s = 1; s <= n_stages; ++s) r.stages.push_back(random_stage(rng, s));
  r.wall_time_s = pick_double(rng);
  r.t_end = pick_double(rng);
  r.steps = static_cast<std::int64_t>(rng() >> 1);
  if (i % 3 == 0) r.rmse = pick_double(rng);
  if (i % 10 == 0) r.trace = random_trace(rng, 100 + static_cast<std::size_t>(i % 50));
  r.finished_at = "2024-01-01T00:00:00.000Z";
  return r;
}

inline void expect_same_run(const RunRecord& want, const RunRecord& got) {
  SCOPED_TRACE("design_index " + std::to_string(want.design_index));
  EXPECT_EQ(want.study_id, got.study_id);
  EXPECT_EQ(want.design_index, got.design_index);
  EXPECT_EQ(want.param_hash, got.param_hash);
  EXPECT_EQ(want.params_json, got.params_json);
  EXPECT_EQ(want.model, got.model);
  expect_same_opt(want.va_over_vd, got.va_over_vd);
  EXPECT_EQ(want.status, got.status);
  EXPECT_EQ(want.error, got.error);
  EXPECT_SAME_DOUBLE(want.wall_time_s, got.wall_time_s);
  EXPECT_SAME_DOUBLE(want.t_end, got.t_end);
  EXPECT_EQ(want.steps, got.steps);
  expect_same_opt(want.rmse, got.rmse);
  EXPECT_EQ(want.finished_at, got.finished_at);
  ASSERT_EQ(want.stages.size(), got.stages.size());
  for (std::size_t s = 0; s < want.stages.size(); ++s) {
    const auto& a = want.stages[s];
    const auto& b = got.stages[s];
    EXPECT_EQ(a.stage, b.stage);
    EXPECT_SAME_DOUBLE(a.t_start, b.t_start);
    EXPECT_SAME_DOUBLE(a.t_end, b.t_end);
    EXPECT_SAME_DOUBLE(a.amplitude, b.amplitude);
    EXPECT_SAME_DOUBLE(a.amplitude_raw, b.amplitude_raw);
    EXPECT_SAME_DOUBLE(a.mean_force, b.mean_force);
    EXPECT_SAME_DOUBLE(a.mean_friction, b.mean_friction);
    EXPECT_EQ(a.slip_events, b.slip_events);
    EXPECT_SAME_DOUBLE(a.mean_period, b.mean_period);
    expect_same_opt(a.rmse, b.rmse);
  }
  EXPECT_TRUE(got.trace.empty()) << "get_runs leaves traces out";
}

/// A small valid run for tests that do not care about values.
inline RunRecord simple_run(const std::string& study, std::int64_t i, const std::string& hash = "") {
  RunRecord r;
  r.study_id = study;
  r.design_index = i;
  r.params_json = R"({"model":"lugre","i":)" + std::to_string(i) + "}";
  r.param_hash = hash.empty() ? stickslip::store::param_hash(r.params_json) : hash;
  r.model = "lugre";
  r.va_over_vd = 0.5 + static_cast<double>(i);
  r.wall_time_s = 0.01;
  r.t_end = 10.0;
  r.steps = 1000 + i;
  for (int s = 1; s <= 3; ++s) {
    StageMetricsRecord m;
    m.stage = s;
    m.amplitude = 0.25 * static_cast<double>(i) + s;
    m.mean_force = 2.0 * s;
    m.slip_events = s;
    r.stages.push_back(m);
  }
  if (i % 4 == 0) {
    r.trace.resize(64);
    for (std::size_t k = 0; k < r.trace.size(); ++k)
      r.trace[k] = {0.01 * static_cast<double>(k), 1.0, 2.0, 3.0, 4.0, static_cast<double>(i)};
  }
  return r;
}

inline NewStudy new_study(const std::string& name, std::int64_t total_runs) {
  NewStudy s;
  s.name = name;
  s.spec_json = R"({"name":")" + name + R"(","design":{"kind":"grid"}})";
  s.spec_hash = stickslip::store::param_hash(s.spec_json);
  s.total_runs = total_runs;
  return s;
}

class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override { db_ = dir_ / "study.db"; }
  /// Creates the database and one study; returns its id.
  std::string make_study(std::int64_t total_runs, const fs::path& db = {}) {
    auto store = Store::open(db.empty() ? db_ : db);
    return store.create_study(new_study("s", total_runs)).study.id;
  }

  stickslip::testing::TempDir tmp_{"stickslip-store"};
  const fs::path& dir_ = tmp_.path();
  fs::path db_;
};

/// Expects fn to throw a StoreError whose message contains every needle.
template <class Fn>
inline void expect_store_error(Fn&& fn, const std::vector<std::string>& needles) {
  try {
    fn();
    ADD_FAILURE() << "no StoreError thrown";
  } catch (const StoreError& e) {
    for (const auto& n : needles)
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos)
          << "message '" << e.what() << "' lacks '" << n << "'";
  }
}

}  // namespace stickslip::store::test_support
