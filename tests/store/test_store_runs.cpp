// Tests of the store's runs: batched writes by the RunWriter, exact read-back (every double bit
// for bit), the views and run counters, idempotent re-adds, rejected records, timed flushes.
#include "stickslip/store/store.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "store_test_support.h"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using namespace stickslip::store::test_support;

// ---------------------------------------------------------------------------------------------
// Runs
// ---------------------------------------------------------------------------------------------

/// Every stored trace equals the generated one, bit for bit; *n_traces counts the runs with one.
void expect_same_traces(Store& store, const std::string& study, const std::vector<RunRecord>& want,
                        std::int64_t* n_traces) {
  for (const auto& w : want) {
    const auto trace = store.get_trace(study, w.design_index);
    ASSERT_EQ(trace.has_value(), !w.trace.empty()) << w.design_index;
    if (!trace) continue;
    ++*n_traces;
    ASSERT_EQ(trace->size(), w.trace.size());
    for (std::size_t k = 0; k < trace->size(); ++k) {
      EXPECT_SAME_DOUBLE((*trace)[k].t, w.trace[k].t);
      EXPECT_SAME_DOUBLE((*trace)[k].F_d, w.trace[k].F_d);
      EXPECT_SAME_DOUBLE((*trace)[k].F_f, w.trace[k].F_f);
      EXPECT_SAME_DOUBLE((*trace)[k].x, w.trace[k].x);
      EXPECT_SAME_DOUBLE((*trace)[k].v, w.trace[k].v);
      EXPECT_SAME_DOUBLE((*trace)[k].s, w.trace[k].s);
    }
  }
}

/// The run counters and the views (v_run_metrics, v_map, v_study_progress) of a study whose
/// runs are want, with expectations computed from the generated records.
void expect_counts_and_views(Store& store, const fs::path& db, const std::string& study,
                             const std::vector<RunRecord>& want) {
  const auto kRuns = static_cast<std::int64_t>(want.size());
  std::int64_t failed = 0, metric_rows = 0, lugre_stage1 = 0;
  for (const auto& w : want) {
    failed += w.status != "ok";
    metric_rows += std::max<std::int64_t>(1, static_cast<std::int64_t>(w.stages.size()));
    lugre_stage1 += w.model == "lugre" && !w.stages.empty();
  }
  const auto counts = store.count_runs(study);
  EXPECT_EQ(counts.total, kRuns);
  EXPECT_EQ(counts.done, kRuns);
  EXPECT_EQ(counts.failed, failed);
  EXPECT_EQ(counts.ok, kRuns - failed);

  RawDb raw(db);
  const std::string q = "WHERE study_id = '" + study + "'";
  EXPECT_EQ(raw.integer("SELECT count(*) FROM v_run_metrics " + q), metric_rows);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM v_run_metrics " + q + " AND stage IS NULL"),
            kRuns / 7 + (kRuns % 7 > 3));  // invalid runs: one row, no stage
  EXPECT_EQ(raw.integer("SELECT count(*) FROM v_map " + q + " AND model = 'lugre' AND stage = 1"),
            lugre_stage1);
  const auto progress =
      raw.rows("SELECT total, done, failed FROM v_study_progress " + q);
  ASSERT_EQ(progress.size(), 1u);
  EXPECT_EQ(progress[0], (std::vector<std::string>{std::to_string(kRuns), std::to_string(kRuns),
                                                   std::to_string(failed)}));
  // One v_map row checked value by value, straight from SQLite.
  const RunRecord& r = want[8];  // ok, 2 stages
  ASSERT_EQ(r.stages.size(), 2u);
  const std::string row = "FROM v_map " + q + " AND design_index = 8 AND stage = 2";
  EXPECT_EQ(raw.text("SELECT model " + row), *r.model);
  EXPECT_EQ(raw.text("SELECT status " + row), "ok");
  EXPECT_SAME_DOUBLE(raw.real("SELECT amplitude " + row), r.stages[1].amplitude);
  EXPECT_SAME_DOUBLE(raw.real("SELECT mean_force " + row), r.stages[1].mean_force);
  EXPECT_SAME_DOUBLE(raw.real("SELECT va_over_vd " + row), *r.va_over_vd);
  EXPECT_EQ(raw.text("SELECT va_over_vd FROM v_map " + q + " AND design_index = 0 AND stage = 1"),
            "NULL");
  EXPECT_EQ(raw.text("SELECT error FROM v_run_metrics " + q + " AND design_index = 3"),
            "reason 3");
  EXPECT_EQ(raw.text("PRAGMA integrity_check"), "ok");
  EXPECT_TRUE(raw.rows("PRAGMA foreign_key_check").empty());
}

TEST_F(StoreTest, ThousandRunsRoundTripExactlyAndViewsAgree) {
  constexpr std::int64_t kRuns = 1000;
  const std::string study = make_study(kRuns);
  std::mt19937_64 rng(7);
  std::vector<RunRecord> want;
  for (std::int64_t i = 0; i < kRuns; ++i) want.push_back(random_run(study, i, rng));
  std::vector<RunRecord> shuffled = want;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  {
    auto writer = RunWriter::open(db_, WriterOptions{.max_batch = 64, .max_delay = 1h});
    auto reader = Store::open(db_, Store::Mode::kReadOnly);
    for (std::size_t k = 0; k < shuffled.size(); ++k) {
      writer.add(shuffled[k]);
      EXPECT_EQ(writer.buffered(), (k + 1) % 64);
      if (k == 62) {
        EXPECT_EQ(reader.count_runs(study).done, 0);  // 63 buffered, none committed
      }
      if (k == 63) {
        EXPECT_EQ(reader.count_runs(study).done, 64);  // one batch committed
      }
    }
    EXPECT_EQ(writer.buffered(), static_cast<std::size_t>(kRuns % 64));
  }  // the destructor commits the last partial batch

  auto store = Store::open(db_, Store::Mode::kReadOnly);
  std::vector<RunRecord> got;
  std::int64_t after = -1;
  for (;;) {
    auto page = store.get_runs(study, after, 300);
    if (page.empty()) break;
    after = page.back().design_index;
    got.insert(got.end(), page.begin(), page.end());
  }
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) expect_same_run(want[i], got[i]);

  std::int64_t n_traces = 0;
  ASSERT_NO_FATAL_FAILURE(expect_same_traces(store, study, want, &n_traces));
  EXPECT_EQ(n_traces, 100);
  ASSERT_NO_FATAL_FAILURE(expect_counts_and_views(store, db_, study, want));
}
TEST_F(StoreTest, NanIsStoredAsNullAndNegativeZeroLosesItsSign) {
  const std::string study = make_study(1);
  RunRecord r = simple_run(study, 0);
  r.stages[0].amplitude = std::numeric_limits<double>::quiet_NaN();
  r.stages[0].mean_force = -0.0;
  r.rmse = std::numeric_limits<double>::quiet_NaN();
  {
    auto w = RunWriter::open(db_);
    w.add(r);
    w.flush();
  }
  auto store = Store::open(db_);
  const auto runs = store.get_runs(study);
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_TRUE(std::isnan(runs[0].stages[0].amplitude));
  EXPECT_EQ(runs[0].stages[0].mean_force, 0.0);
  EXPECT_FALSE(runs[0].rmse.has_value());
}

TEST_F(StoreTest, ReAddingARunNeverDuplicatesIt) {
  const std::string study = make_study(10);
  auto writer = RunWriter::open(db_);
  for (std::int64_t i : {0, 2, 4, 6, 8}) writer.add(simple_run(study, i));
  FlushResult f = writer.flush();
  EXPECT_EQ(f.inserted, 5u);
  EXPECT_EQ(f.duplicates, 0u);

  // Same runs again, with different metrics but the same param_hash: left untouched.
  for (std::int64_t i : {0, 2, 4, 6, 8}) {
    RunRecord r = simple_run(study, i);
    r.stages[0].amplitude = -1.0;
    r.stages.pop_back();
    r.trace.clear();
    writer.add(r);
  }
  writer.add(simple_run(study, 9));
  f = writer.flush();
  EXPECT_EQ(f.inserted, 1u);
  EXPECT_EQ(f.duplicates, 5u);

  auto store = Store::open(db_, Store::Mode::kReadOnly);
  EXPECT_EQ(store.completed_design_indices(study), (std::vector<std::int64_t>{0, 2, 4, 6, 8, 9}));
  EXPECT_EQ(store.count_runs(study).done, 6);
  const auto runs = store.get_runs(study);
  ASSERT_EQ(runs.size(), 6u);
  EXPECT_EQ(runs[0].stages.size(), 3u);
  EXPECT_EQ(runs[0].stages[0].amplitude, 1.0);
  EXPECT_TRUE(store.get_trace(study, 0));
  RawDb raw(db_);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM stage_metrics"), 18);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM traces"), 3);  // indices 0, 4, 8
}

// The run counters of each study (schema version 3) are kept by triggers, so they agree with
// the runs table after every kind of change: batched inserts, duplicates and rejected runs,
// an edited status, deleted runs, and a deleted study.
TEST_F(StoreTest, RunCountersFollowEveryChangeOfTheRuns) {
  const std::string a = make_study(20);
  const std::string b = make_study(5);
  RawDb raw(db_);
  const auto expect_counts_match_runs = [&](const std::string& study, const char* when) {
    auto store = Store::open(db_, Store::Mode::kReadOnly);
    const auto c = store.count_runs(study);
    const std::string where = " FROM runs WHERE study_id = '" + study + "'";
    EXPECT_EQ(c.done, raw.integer("SELECT count(*)" + where)) << when;
    EXPECT_EQ(c.ok, raw.integer("SELECT count(*)" + where + " AND status = 'ok'")) << when;
    EXPECT_EQ(c.failed, raw.integer("SELECT count(*)" + where + " AND status <> 'ok'")) << when;
    EXPECT_EQ(c.done, c.ok + c.failed) << when;
    return c;
  };
  {
    auto writer = RunWriter::open(db_, WriterOptions{.max_batch = 4, .max_delay = 1h});
    for (std::int64_t i = 0; i < 10; ++i) {
      RunRecord r = simple_run(a, i);
      if (i % 3 == 0) {
        r.status = "diverged";
        r.error = "t = 1 s: |x| > 1 m";
      }
      writer.add(r);
    }
    writer.add(simple_run(b, 0));
    writer.flush();
  }
  auto c = expect_counts_match_runs(a, "after the first batches");
  EXPECT_EQ(c.done, 10);
  EXPECT_EQ(c.failed, 4);  // 0, 3, 6, 9
  EXPECT_EQ(expect_counts_match_runs(b, "other study").done, 1);
  {
    // Duplicates and a run left out for another param_hash change nothing.
    auto writer = RunWriter::open(db_);
    writer.add(simple_run(a, 1));
    writer.add(simple_run(a, 2, "0123456789abcdef"));
    writer.add(simple_run(a, 10));
    EXPECT_THROW(writer.flush(), StoreError);
  }
  c = expect_counts_match_runs(a, "after duplicates and a conflict");
  EXPECT_EQ(c.done, 11);
  raw.exec("UPDATE runs SET status = 'invalid' WHERE study_id = '" + a + "' AND design_index = 1");
  EXPECT_EQ(expect_counts_match_runs(a, "after a status edit").failed, 5);
  raw.exec("DELETE FROM runs WHERE study_id = '" + a + "' AND design_index IN (0, 2)");
  c = expect_counts_match_runs(a, "after deleting two runs");
  EXPECT_EQ(c.done, 9);
  EXPECT_EQ(c.failed, 4);
  raw.exec("PRAGMA foreign_keys = ON");
  raw.exec("DELETE FROM studies WHERE id = '" + a + "'");  // cascades to its runs
  EXPECT_EQ(raw.integer("SELECT count(*) FROM runs WHERE study_id = '" + a + "'"), 0);
  EXPECT_EQ(expect_counts_match_runs(b, "after deleting the other study").done, 1);
  EXPECT_EQ(raw.text("PRAGMA integrity_check"), "ok");
}

TEST_F(StoreTest, ParamHashMismatchAndUnknownStudyAreReportedOthersCommitted) {
  const std::string study = make_study(10);
  auto writer = RunWriter::open(db_);
  writer.add(simple_run(study, 1));
  writer.flush();
  writer.add(simple_run(study, 1, "0123456789abcdef"));  // same index, other parameters
  writer.add(simple_run("st-unknown", 2));               // foreign key violation
  writer.add(simple_run(study, 3));
  expect_store_error([&] { writer.flush(); },
                     {db_.string(), "left out 2", "(" + study + ", 1)", "different param_hash",
                      "(st-unknown, 2)", "FOREIGN KEY"});
  EXPECT_EQ(writer.buffered(), 0u);
  auto store = Store::open(db_, Store::Mode::kReadOnly);
  EXPECT_EQ(store.completed_design_indices(study), (std::vector<std::int64_t>{1, 3}));
  EXPECT_EQ(store.get_runs(study).at(0).param_hash, simple_run(study, 1).param_hash);
  RawDb raw(db_);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM stage_metrics"), 6);
}

TEST_F(StoreTest, BadRecordsAreRejectedAtAdd) {
  const std::string study = make_study(10);
  auto writer = RunWriter::open(db_);
  RunRecord r = simple_run(study, 0);
  r.status = "crashed";
  expect_store_error([&] { writer.add(r); }, {"status 'crashed'"});
  r = simple_run(study, 0);
  r.params_json = "[1, 2]";
  expect_store_error([&] { writer.add(r); }, {"params_json"});
  r = simple_run(study, 0);
  r.stages[1].stage = 1;
  expect_store_error([&] { writer.add(r); }, {"repeated stage"});
  r = simple_run(study, -1);
  expect_store_error([&] { writer.add(r); }, {"negative design_index"});
  EXPECT_EQ(writer.buffered(), 0u);
  // stage 0 means "number by position".
  r = simple_run(study, 0);
  for (auto& m : r.stages) m.stage = 0;
  writer.add(r);
  writer.flush();
  auto store = Store::open(db_);
  const auto runs = store.get_runs(study);
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(runs[0].stages.at(2).stage, 3);
}

TEST_F(StoreTest, TimeBasedFlush) {
  const std::string study = make_study(10);
  auto writer = RunWriter::open(db_, WriterOptions{.max_batch = 1000, .max_delay = 300ms});
  writer.add(simple_run(study, 0));
  EXPECT_EQ(writer.buffered(), 1u);
  EXPECT_FALSE(writer.flush_if_due());
  std::this_thread::sleep_for(350ms);
  EXPECT_TRUE(writer.flush_if_due());
  EXPECT_EQ(writer.buffered(), 0u);
  writer.add(simple_run(study, 1));
  EXPECT_EQ(writer.buffered(), 1u);  // the clock restarted at the last commit
  std::this_thread::sleep_for(350ms);
  writer.add(simple_run(study, 2));  // add() itself commits when due
  EXPECT_EQ(writer.buffered(), 0u);
  EXPECT_EQ(Store::open(db_).count_runs(study).done, 3);
}

TEST_F(StoreTest, MovedWriterFlushesOnce) {
  const std::string study = make_study(10);
  {
    auto a = RunWriter::open(db_);
    a.add(simple_run(study, 0));
    RunWriter b = std::move(a);
    b.add(simple_run(study, 1));
    auto c = RunWriter::open(db_);
    c.add(simple_run(study, 2));
    c = std::move(b);  // c's own buffer (run 2) is flushed first
    EXPECT_EQ(c.buffered(), 2u);
  }
  EXPECT_EQ(Store::open(db_).completed_design_indices(study),
            (std::vector<std::int64_t>{0, 1, 2}));
}

}  // namespace
