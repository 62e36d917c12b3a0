// The diagnoses table (schema version 2) and the migration of a version-1 database: a copy of
// tests/data/store_v1.db, made by the stickslip build before diagnoses existed (commit ecc7c3f,
// `stickslip study run tests/data/store_v1.spec.json --db store_v1.db`: one succeeded study of 4
// runs), is opened by this build: everything in it is kept, the diagnoses table is added, and
// the file is then an ordinary version-2 store.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "stickslip/store/store.h"
#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using namespace stickslip::store;

/// One text value of a query, via a plain read-only SQLite connection.
std::string query_text(const fs::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK)
    throw std::runtime_error("open " + db.string());
  sqlite3_stmt* st = nullptr;
  std::string out = "<no row>";
  if (sqlite3_prepare_v2(h, sql.c_str(), -1, &st, nullptr) != SQLITE_OK) {
    out = std::string("<error: ") + sqlite3_errmsg(h) + ">";
  } else if (sqlite3_step(st) == SQLITE_ROW) {
    const auto* t = sqlite3_column_text(st, 0);
    out = t != nullptr ? reinterpret_cast<const char*>(t) : "NULL";
  }
  sqlite3_finalize(st);
  sqlite3_close_v2(h);
  return out;
}

std::string file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class StoreDiagnoses : public ::testing::Test {
 protected:
  fs::path copy_v1() {
    const fs::path db = tmp_ / "v1.db";
    fs::copy_file(fs::path(STICKSLIP_SOURCE_DIR) / "tests/data/store_v1.db", db);
    return db;
  }
  stickslip::testing::TempDir tmp_{"stickslip-store-diag"};
};

TEST_F(StoreDiagnoses, Version1DatabaseIsMigratedAndKeepsEverything) {
  const fs::path db = copy_v1();
  ASSERT_EQ(query_text(db, "SELECT value FROM meta WHERE key = 'schema_version'"), "1");
  ASSERT_EQ(query_text(db, "SELECT count(*) FROM sqlite_master WHERE name = 'diagnoses'"), "0");
  const std::string runs_before =
      query_text(db, "SELECT group_concat(design_index || ':' || param_hash || ':' || "
                     "quote(rmse) || ':' || status, ';') FROM (SELECT * FROM runs ORDER BY "
                     "design_index)");
  const std::string stages_before = query_text(
      db, "SELECT count(*) || ':' || total(amplitude) || ':' || total(mean_force) FROM stage_metrics");
  {
    auto store = Store::open(db);
    const auto studies = store.list_studies(10);
    ASSERT_EQ(studies.size(), 1u);
    EXPECT_EQ(studies[0].name, "v1-fixture");
    EXPECT_EQ(studies[0].state, StudyState::kSucceeded);
    EXPECT_EQ(store.count_runs(studies[0].id).done, 4);
    EXPECT_EQ(store.get_runs(studies[0].id).size(), 4u);
    // The new table works at once.
    NewDiagnosis nd;
    nd.name = "after-migration";
    nd.request_json = R"({"manifest": {}, "files": {}})";
    nd.request_hash = param_hash(nd.request_json);
    const auto created = store.create_diagnosis(nd);
    EXPECT_TRUE(created.created);
    EXPECT_EQ(store.get_diagnosis(created.diagnosis.id)->name, "after-migration");
  }
  EXPECT_EQ(query_text(db, "SELECT value FROM meta WHERE key = 'schema_version'"),
            std::to_string(kStoreSchemaVersion));  // 1 -> 2 -> 3 in one open
  EXPECT_NE(query_text(db, "SELECT value FROM meta WHERE key = 'migrated_at'"), "<no row>");
  EXPECT_EQ(query_text(db, "SELECT group_concat(design_index || ':' || param_hash || ':' || "
                           "quote(rmse) || ':' || status, ';') FROM (SELECT * FROM runs ORDER BY "
                           "design_index)"),
            runs_before);
  EXPECT_EQ(query_text(db, "SELECT count(*) || ':' || total(amplitude) || ':' || total(mean_force) "
                           "FROM stage_metrics"),
            stages_before);
  EXPECT_EQ(query_text(db, "PRAGMA integrity_check"), "ok");
  // Opening again is an ordinary open: the diagnosis is still there, nothing migrates twice.
  auto again = Store::open(db);
  EXPECT_EQ(again.list_diagnoses(10).size(), 1u);
  EXPECT_EQ(again.list_studies(10).size(), 1u);
}

TEST_F(StoreDiagnoses, ReadOnlyOpenOfVersion1ReadsStudiesAndChangesNothing) {
  const fs::path db = copy_v1();
  const std::string before = file_bytes(db);
  {
    auto store = Store::open(db, Store::Mode::kReadOnly);
    EXPECT_EQ(store.list_studies(10).size(), 1u);
    EXPECT_TRUE(store.list_diagnoses(10).empty());  // read through a TEMP jobs view (version 5)
  }
  EXPECT_EQ(file_bytes(db), before);
}

// tests/data/store_v2.db: made by the version-2 build (commit d573fe6, `stickslip study run
// tests/data/store_v2.spec.json --db store_v2.db`): one succeeded study of 4 runs, 2 of them
// invalid (F_C = 12 N > F_S). Version 3 adds the run counters, filled from the runs.
TEST_F(StoreDiagnoses, Version2DatabaseGetsRunCountersFilledFromItsRuns) {
  const fs::path db = tmp_ / "v2.db";
  fs::copy_file(fs::path(STICKSLIP_SOURCE_DIR) / "tests/data/store_v2.db", db);
  ASSERT_EQ(query_text(db, "SELECT value FROM meta WHERE key = 'schema_version'"), "2");
  const std::string runs_sql =
      "SELECT group_concat(design_index || ':' || param_hash || ':' || quote(rmse) || ':' || "
      "status, ';') FROM (SELECT * FROM runs ORDER BY design_index)";
  const std::string runs_before = query_text(db, runs_sql);
  {
    // Read-only: read as it is, counted by the version-2 aggregate view, file unchanged.
    const std::string bytes = file_bytes(db);
    auto ro = Store::open(db, Store::Mode::kReadOnly);
    const auto studies = ro.list_studies(10);
    ASSERT_EQ(studies.size(), 1u);
    const auto c = ro.count_runs(studies[0].id);
    EXPECT_EQ(c.done, 4);
    EXPECT_EQ(c.failed, 2);
    EXPECT_EQ(file_bytes(db), bytes);
  }
  std::string id;
  {
    auto store = Store::open(db);
    const auto studies = store.list_studies(10);
    ASSERT_EQ(studies.size(), 1u);
    id = studies[0].id;
    const auto c = store.count_runs(id);
    EXPECT_EQ(c.total, 4);
    EXPECT_EQ(c.done, 4);
    EXPECT_EQ(c.ok, 2);
    EXPECT_EQ(c.failed, 2);
  }
  // 2 -> 3 -> 4 -> 5 in one open: version 4 adds the (empty) diagnosis_traces table.
  EXPECT_EQ(query_text(db, "SELECT value FROM meta WHERE key = 'schema_version'"),
            std::to_string(kStoreSchemaVersion));
  EXPECT_EQ(query_text(db, "SELECT count(*) FROM diagnosis_traces"), "0");
  EXPECT_EQ(query_text(db, "SELECT runs_done || '/' || runs_ok || '/' || runs_failed FROM studies"),
            "4/2/2");
  // Three run-counter triggers, and (version 5) the four that insert and delete through the views.
  EXPECT_EQ(query_text(db, "SELECT count(*) FROM sqlite_master WHERE type = 'trigger'"), "7");
  EXPECT_EQ(query_text(db, runs_sql), runs_before);
  EXPECT_EQ(query_text(db, "PRAGMA integrity_check"), "ok");
  // A migrated file and a new one have the same tables, columns, views and triggers.
  const fs::path fresh = tmp_ / "fresh.db";
  { auto store = Store::open(fresh); }
  const std::string schema_sql =
      "SELECT group_concat(type || ' ' || name, ', ') FROM (SELECT type, name FROM sqlite_master "
      "ORDER BY type, name)";
  EXPECT_EQ(query_text(db, schema_sql), query_text(fresh, schema_sql));
  const std::string columns_sql =
      "SELECT group_concat(name || ' ' || type || ' ' || \"notnull\" || ' ' || "
      "quote(dflt_value), ', ') FROM pragma_table_info('studies')";
  EXPECT_EQ(query_text(db, columns_sql), query_text(fresh, columns_sql));
}

TEST_F(StoreDiagnoses, CreateStateFinishAndCancelRules) {
  auto store = Store::open(tmp_ / "d.db");
  NewDiagnosis nd;
  nd.name = "stand";
  nd.request_json = R"({"manifest": {"name": "stand"}, "files": {"a.csv": "t,Fd\n"}})";
  nd.request_hash = param_hash(nd.request_json);
  nd.idempotency_key = "k1";
  const auto a = store.create_diagnosis(nd);
  ASSERT_TRUE(a.created);
  EXPECT_TRUE(a.diagnosis.id.starts_with("dg-"));
  EXPECT_EQ(a.diagnosis.state, StudyState::kQueued);
  EXPECT_FALSE(a.diagnosis.result_json);
  EXPECT_EQ(*store.get_diagnosis_request(a.diagnosis.id), nd.request_json);
  // The same key returns the stored row.
  const auto again = store.create_diagnosis(nd);
  EXPECT_FALSE(again.created);
  EXPECT_EQ(again.diagnosis.id, a.diagnosis.id);
  EXPECT_EQ(store.find_diagnosis_by_idempotency_key("k1")->id, a.diagnosis.id);
  // Not an object: rejected.
  NewDiagnosis bad = nd;
  bad.idempotency_key.reset();
  bad.request_json = "[1]";
  EXPECT_THROW(store.create_diagnosis(bad), StoreError);

  store.set_diagnosis_state(a.diagnosis.id, StudyState::kRunning);
  EXPECT_TRUE(store.get_diagnosis(a.diagnosis.id)->started_at);
  EXPECT_TRUE(store.requeue_diagnosis(a.diagnosis.id));
  EXPECT_FALSE(store.requeue_diagnosis(a.diagnosis.id));  // queued already
  EXPECT_TRUE(store.finish_diagnosis(a.diagnosis.id, StudyState::kSucceeded, R"({"cause": "none"})"));
  auto rec = store.get_diagnosis(a.diagnosis.id);
  EXPECT_EQ(rec->state, StudyState::kSucceeded);
  EXPECT_EQ(*rec->result_json, R"({"cause": "none"})");
  EXPECT_TRUE(rec->finished_at);
  // A finished (or cancelled) diagnosis takes no other result.
  EXPECT_FALSE(store.finish_diagnosis(a.diagnosis.id, StudyState::kFailed, std::nullopt, "late"));
  EXPECT_EQ(store.get_diagnosis(a.diagnosis.id)->state, StudyState::kSucceeded);

  NewDiagnosis nd2 = nd;
  nd2.idempotency_key.reset();
  const auto b = store.create_diagnosis(nd2);
  store.set_diagnosis_state(b.diagnosis.id, StudyState::kCancelled);
  EXPECT_FALSE(store.finish_diagnosis(b.diagnosis.id, StudyState::kSucceeded, "{}"));
  EXPECT_EQ(store.get_diagnosis(b.diagnosis.id)->state, StudyState::kCancelled);
  EXPECT_FALSE(store.get_diagnosis(b.diagnosis.id)->result_json);
  EXPECT_THROW(store.set_diagnosis_state("dg-nope", StudyState::kRunning), StoreError);

  // Keyset pagination in creation order, without results.
  const auto page1 = store.list_diagnoses(1);
  ASSERT_EQ(page1.size(), 1u);
  EXPECT_EQ(page1[0].id, a.diagnosis.id);
  EXPECT_FALSE(page1[0].result_json);
  const auto page2 = store.list_diagnoses(5, page1[0].id);
  ASSERT_EQ(page2.size(), 1u);
  EXPECT_EQ(page2[0].id, b.diagnosis.id);
}

TEST_F(StoreDiagnoses, TracesAreStoredWithTheOutcomeInOneTransaction) {
  auto store = Store::open(tmp_ / "t.db");
  NewDiagnosis nd;
  nd.name = "traces";
  nd.request_json = R"({"manifest": {}})";
  nd.request_hash = param_hash(nd.request_json);
  const std::string id = store.create_diagnosis(nd).diagnosis.id;
  DiagnosisTrace a{"va0", {0.0, 0.5, 1.0}, {1.0, -2.5, 3.25}, {1.1, -2.4, 3.0}, {1.0, -2.5, 3.2}};
  DiagnosisTrace b{"va4", {0.0, 0.5}, {0.1, 0.2}, {0.3, 0.4}, {}};  // no extended model
  EXPECT_TRUE(store.list_diagnosis_traces(id).empty());

  // Series of different lengths: refused, and nothing changes (not even the state).
  DiagnosisTrace bad = a;
  bad.base.pop_back();
  EXPECT_THROW(store.finish_diagnosis(id, StudyState::kSucceeded, "{}", std::nullopt, {a, bad}),
               StoreError);
  EXPECT_EQ(store.get_diagnosis(id)->state, StudyState::kQueued);
  EXPECT_TRUE(store.list_diagnosis_traces(id).empty());

  ASSERT_TRUE(store.finish_diagnosis(id, StudyState::kSucceeded, R"({"cause": "none"})",
                                     std::nullopt, {a, b}));
  const auto list = store.list_diagnosis_traces(id);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].run_index, 0);
  EXPECT_EQ(list[0].run, "va0");
  EXPECT_EQ(list[0].samples, 3);
  EXPECT_EQ(list[0].t_first, 0.0);
  EXPECT_EQ(list[0].t_last, 1.0);
  EXPECT_TRUE(list[0].has_extended);
  EXPECT_EQ(list[1].run, "va4");
  EXPECT_FALSE(list[1].has_extended);
  const auto got = store.get_diagnosis_trace(id, 0);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->t, a.t);  // bit for bit
  EXPECT_EQ(got->measured, a.measured);
  EXPECT_EQ(got->base, a.base);
  EXPECT_EQ(got->extended, a.extended);
  EXPECT_TRUE(store.get_diagnosis_trace(id, 1)->extended.empty());
  EXPECT_FALSE(store.get_diagnosis_trace(id, 2));

  // A cancelled diagnosis takes no result and no traces.
  const std::string other = store.create_diagnosis(nd).diagnosis.id;
  store.set_diagnosis_state(other, StudyState::kCancelled);
  EXPECT_FALSE(store.finish_diagnosis(other, StudyState::kSucceeded, "{}", std::nullopt, {a}));
  EXPECT_TRUE(store.list_diagnosis_traces(other).empty());
  EXPECT_TRUE(store.list_diagnosis_traces("dg-unknown").empty());
}

}  // namespace
