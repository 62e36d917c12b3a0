// The job records of schema version 5 (one jobs table for every kind of job), the migration of
// a version-3 file into it, the indexed claim query, ordered ids, the single-writer lock, the
// start-up check of a damaged file, and commits on a busy store.
//
// tests/data/store_v3.db: made by the version-3 build (commit 46621d2): `stickslip study run
// tests/data/store_v3.first.spec.json` (one succeeded study of 4 runs, 2 invalid, traces), then
// stickslipd with curl: tests/data/store_v3.spec.json submitted twice (the first with
// Idempotency-Key fixture-key-1: 16 of 20 runs stored when SIGTERM re-queued it; the second
// cancelled at once), and two diagnoses (one queued with the same Idempotency-Key fixture-key-1,
// one cancelled).
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "stickslip/store/store.h"
#include "stickslip/store/writer_lock.h"
#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using namespace stickslip::store;

/// A plain SQLite connection (no stickslip code): the test's view of the file.
class Raw {
 public:
  explicit Raw(const fs::path& db, bool read_only = true) {
    sqlite3_open_v2(db.c_str(), &h_, read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE,
                    nullptr);
    sqlite3_busy_timeout(h_, 100);
  }
  ~Raw() { sqlite3_close_v2(h_); }
  /// Column col of the first row (rows joined by "; " when all_rows).
  std::string text(const std::string& sql, int col = 0, bool all_rows = false) const {
    sqlite3_stmt* st = nullptr;
    std::string out = "<no row>";
    if (sqlite3_prepare_v2(h_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      out = std::string("<error: ") + sqlite3_errmsg(h_) + ">";
    else
      for (bool first = true; sqlite3_step(st) == SQLITE_ROW; first = false) {
        const auto* t = sqlite3_column_text(st, col);
        const std::string v = t != nullptr ? reinterpret_cast<const char*>(t) : "NULL";
        out = first ? v : out + "; " + v;
        if (!all_rows) break;
      }
    sqlite3_finalize(st);
    return out;
  }
  void exec(const std::string& sql) const {
    ASSERT_EQ(sqlite3_exec(h_, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
        << sql << ": " << sqlite3_errmsg(h_);
  }

 private:
  sqlite3* h_ = nullptr;
};

std::string file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

RunRecord run_of(const std::string& study, std::int64_t i, std::size_t trace = 0) {
  RunRecord r;
  r.study_id = study;
  r.design_index = i;
  r.params_json = R"({"k":)" + std::to_string(i) + "}";
  r.param_hash = param_hash(r.params_json);
  r.steps = 10;
  r.stages.push_back({});
  r.trace.resize(trace);
  for (std::size_t k = 0; k < trace; ++k) r.trace[k] = {0.1 * double(k), 1, 2, 3, 4, double(i)};
  return r;
}

std::string new_study(Store& store, const std::string& name, std::int64_t runs) {
  NewStudy s;
  s.name = name;
  s.spec_json = R"({"name":")" + name + R"("})";
  s.spec_hash = param_hash(s.spec_json);
  s.total_runs = runs;
  return store.create_study(s).study.id;
}

class StoreJobs : public ::testing::Test {
 protected:
  stickslip::testing::TempDir tmp_{"stickslip-store-jobs"};
  fs::path db_ = tmp_.path() / "s.db";
};

/// Everything a reader sees of the studies and diagnoses of a store, one line each.
std::string describe_all(Store& store) {
  std::string out;
  for (const auto& s : store.list_studies(100)) {
    const auto c = store.count_runs(s.id);
    out += s.id + "|" + s.name + "|" + to_string(s.state) + "|" + s.spec_json + "|" + s.spec_hash +
           "|" + std::to_string(s.total_runs) + "|" + s.created_at + "|" +
           s.started_at.value_or("-") + "|" + s.finished_at.value_or("-") + "|" +
           s.error.value_or("-") + "|" + s.idempotency_key.value_or("-") + "|" +
           s.request_hash.value_or("-") + "|" + std::to_string(c.done) + "/" +
           std::to_string(c.ok) + "/" + std::to_string(c.failed) + "\n";
  }
  for (const auto& d : store.list_diagnoses(100)) {
    const auto full = store.get_diagnosis(d.id);
    out += d.id + "|" + d.name + "|" + to_string(d.state) + "|" + d.request_hash + "|" +
           d.created_at + "|" + d.started_at.value_or("-") + "|" + d.finished_at.value_or("-") +
           "|" + d.error.value_or("-") + "|" + d.idempotency_key.value_or("-") + "|" +
           full->result_json.value_or("-") + "|" +
           std::to_string(store.get_diagnosis_request(d.id)->size()) + "\n";
  }
  return out;
}

TEST_F(StoreJobs, Version3DatabaseMovesIntoTheJobsTableAndKeepsEverything) {
  fs::copy_file(fs::path(STICKSLIP_SOURCE_DIR) / "tests/data/store_v3.db", db_);
  ASSERT_EQ(Raw(db_).text("SELECT value FROM meta WHERE key = 'schema_version'"), "3");
  const std::string runs_sql =
      "SELECT group_concat(study_id || ':' || design_index || ':' || param_hash || ':' || "
      "status || ':' || quote(rmse), ';') FROM (SELECT * FROM runs ORDER BY 1, 2)";
  const std::string traces_sql =
      "SELECT group_concat(hex(t) || hex(F_d) || hex(s), ';') FROM (SELECT * FROM traces "
      "ORDER BY 1, 2)";
  const std::string runs_before = Raw(db_).text(runs_sql), traces_before = Raw(db_).text(traces_sql);
  std::string seen_v3;
  {
    // Read-only: read as it is (through TEMP views), the file unchanged.
    const std::string bytes = file_bytes(db_);
    auto ro = Store::open(db_, Store::Mode::kReadOnly);
    seen_v3 = describe_all(ro);
    EXPECT_EQ(file_bytes(db_), bytes);
  }
  EXPECT_EQ(std::count(seen_v3.begin(), seen_v3.end(), '\n'), 5) << seen_v3;
  EXPECT_NE(seen_v3.find("|queued|"), std::string::npos);
  EXPECT_NE(seen_v3.find("|cancelled|"), std::string::npos);
  EXPECT_NE(seen_v3.find("|16/16/0\n"), std::string::npos) << seen_v3;
  std::string seen_v4;
  {
    auto store = Store::open(db_);
    seen_v4 = describe_all(store);
    // The same Idempotency-Key served one study and one diagnosis: unique per kind.
    EXPECT_TRUE(store.find_by_idempotency_key("fixture-key-1"));
    EXPECT_TRUE(store.find_diagnosis_by_idempotency_key("fixture-key-1"));
    EXPECT_EQ(store.pending_jobs("study", 10).size(), 1u);
    EXPECT_EQ(store.pending_jobs("diagnosis", 10).size(), 1u);
  }
  EXPECT_EQ(seen_v4, seen_v3);
  Raw raw(db_);
  EXPECT_EQ(raw.text("SELECT value FROM meta WHERE key = 'schema_version'"),
            std::to_string(kStoreSchemaVersion));
  EXPECT_EQ(raw.text(runs_sql), runs_before);
  EXPECT_EQ(raw.text(traces_sql), traces_before);
  EXPECT_EQ(raw.text("PRAGMA integrity_check"), "ok");
  EXPECT_EQ(raw.text("SELECT count(*) FROM pragma_foreign_key_check"), "0");
  EXPECT_EQ(raw.text("SELECT count(*) FROM jobs"), "5");
  EXPECT_EQ(raw.text("SELECT count(*) FROM diagnosis_traces"), "0");
  // The views keep queries written for version 3 working.
  EXPECT_EQ(raw.text("SELECT count(*) FROM studies WHERE runs_done = 16"), "1");
  EXPECT_EQ(raw.text("SELECT count(*) FROM diagnoses WHERE state = 'cancelled'"), "1");
  // A migrated file and a new one have the same schema, object for object.
  const fs::path fresh = tmp_.path() / "fresh.db";
  { auto store = Store::open(fresh); }
  const std::string schema_sql =
      "SELECT group_concat(type || ' ' || name || ' ' || coalesce(sql, ''), char(10)) FROM "
      "(SELECT * FROM sqlite_master ORDER BY type, name)";
  EXPECT_EQ(raw.text(schema_sql), Raw(fresh).text(schema_sql));
}

TEST_F(StoreJobs, ClaimQueryIsOneRangeOfThePendingIndex) {
  { auto store = Store::open(db_); }
  Raw raw(db_);
  const std::string plan = raw.text(
      "EXPLAIN QUERY PLAN SELECT id FROM jobs INDEXED BY jobs_pending WHERE kind = 'study' "
      "AND state IN ('queued', 'running') ORDER BY id LIMIT 2",
      3, true);
  EXPECT_NE(plan.find("jobs_pending"), std::string::npos) << plan;
  EXPECT_EQ(plan.find("TEMP B-TREE"), std::string::npos) << plan;
  EXPECT_EQ(plan.find("SCAN jobs"), std::string::npos) << plan;
}

TEST_F(StoreJobs, PendingJobsAreTheQueuedAndRunningOfOneKindInCreationOrder) {
  auto store = Store::open(db_);
  std::vector<std::string> ids;
  for (int i = 0; i < 6; ++i) ids.push_back(new_study(store, "s" + std::to_string(i), 1));
  NewJob other;
  other.kind = "validation";
  other.name = "v";
  other.request_json = "{}";
  const auto v = store.create_job(other).job;
  EXPECT_TRUE(v.id.starts_with("va-"));
  store.set_study_state(ids[0], StudyState::kSucceeded);
  store.set_study_state(ids[2], StudyState::kCancelled);
  EXPECT_TRUE(store.claim_job(ids[3]));
  EXPECT_EQ(store.get_job(ids[3])->state, StudyState::kRunning);
  EXPECT_FALSE(store.claim_job(ids[0]));  // finished: not claimable
  EXPECT_EQ(store.pending_jobs("study", 10),
            (std::vector<std::string>{ids[1], ids[3], ids[4], ids[5]}));
  EXPECT_EQ(store.pending_jobs("study", 2), (std::vector<std::string>{ids[1], ids[3]}));
  EXPECT_EQ(store.pending_jobs("validation", 10), (std::vector<std::string>{v.id}));
  // finish_job stores only while queued or running; requeue keeps an error for the user.
  EXPECT_TRUE(store.requeue_job(ids[3], "store fault: disk I/O error"));
  EXPECT_EQ(*store.get_job(ids[3])->error, "store fault: disk I/O error");
  EXPECT_TRUE(store.finish_job(v.id, StudyState::kSucceeded, R"({"ok": true})"));
  EXPECT_FALSE(store.finish_job(v.id, StudyState::kFailed, std::nullopt, "late"));
  EXPECT_EQ(*store.get_job(v.id, {.request = false, .result = true})->result_json,
            R"({"ok": true})");
}

TEST(StoreIds, IdsMadeInOneMillisecondSortInCreationOrder) {
  // Before: 12 hex digits of the time in ms + 8 random ones, so two ids of one millisecond
  // sorted at random (StoreDiagnoses.CreateStateFinishAndCancelRules failed now and then).
  std::string last;
  for (int i = 0; i < 20000; ++i) {
    const std::string id = new_job_id("st");
    ASSERT_EQ(id.size(), 23u) << id;
    ASSERT_GT(id, last) << "id " << i << " sorts before the one made before it";
    last = id;
  }
}

TEST_F(StoreJobs, AnotherProcessCannotOpenTheStoreForWritingAndIsToldWhoHoldsIt) {
  { auto store = Store::open(db_); }  // created, then closed: nobody holds the lock
  int ready[2], done[2];
  ASSERT_EQ(pipe(ready), 0);
  ASSERT_EQ(pipe(done), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {  // the holder: opens read-write, names itself, waits until told to go
    close(ready[0]);
    close(done[1]);
    try {
      auto store = Store::open(db_);
      auto lock = WriterLock::acquire(db_, "holder-test");
      lock.set_url("http://127.0.0.1:1");
      char c = 'r';
      if (write(ready[1], &c, 1) != 1) _exit(3);
      if (read(done[0], &c, 1) < 0) _exit(4);
    } catch (...) {
      _exit(2);
    }
    _exit(0);
  }
  close(ready[1]);
  close(done[0]);
  char c = 0;
  ASSERT_EQ(read(ready[0], &c, 1), 1);
  try {
    auto second = Store::open(db_);
    ADD_FAILURE() << "a second writer opened the store";
  } catch (const StoreLockedError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("pid " + std::to_string(pid)), std::string::npos) << what;
    EXPECT_NE(what.find("holder-test"), std::string::npos) << what;
    EXPECT_NE(what.find("http://127.0.0.1:1"), std::string::npos) << what;
    ASSERT_TRUE(e.holder());
    EXPECT_EQ(e.holder()->pid, pid);
  }
  EXPECT_THROW(RunWriter::open(db_), StoreLockedError);
  {
    auto ro = Store::open(db_, Store::Mode::kReadOnly);  // readers never need the lock
    EXPECT_TRUE(ro.list_studies(1).empty());
  }
  const auto holder = WriterLock::holder(db_);
  ASSERT_TRUE(holder);
  EXPECT_EQ(holder->program, "holder-test");
  close(done[1]);  // the holder exits, and the kernel drops its lock
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_FALSE(WriterLock::holder(db_));
  EXPECT_NO_THROW(Store::open(db_));
  close(ready[0]);
}

TEST_F(StoreJobs, OneProcessSharesItsLockBetweenItsConnections) {
  auto a = Store::open(db_);
  auto lock = WriterLock::acquire(db_, "me");
  auto b = Store::open(db_);
  auto w = RunWriter::open(db_);
  EXPECT_EQ(WriterLock::holder(db_)->pid, getpid());
  EXPECT_EQ(WriterLock::holder(db_)->program, "me");
}

TEST_F(StoreJobs, DamagedFileIsRefusedBeforeAnyWriteAndTheFullCheckNamesTheDamage) {
  {
    auto store = Store::open(db_);
    const std::string study = new_study(store, "big", 600);
    auto w = RunWriter::open(db_);
    for (int i = 0; i < 600; ++i) w.add(run_of(study, i, 64));
    w.flush();
  }
  Raw(db_, false).exec("PRAGMA wal_checkpoint(TRUNCATE)");
  ASSERT_GT(fs::file_size(db_), 1u << 21) << "too small to damage at 1 MiB";
  {
    // 8 KB of garbage at 1 MiB (issue 18, defect 5).
    std::fstream f(db_, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(1 << 20);
    const std::string junk(8192, '\xab');
    f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
  }
  const std::string bytes = file_bytes(db_);
  try {
    auto store = Store::open(db_);
    store.create_study({"", "after", "{}", param_hash("{}"), 1, std::nullopt, std::nullopt});
    ADD_FAILURE() << "a damaged store was opened for writing";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("damaged"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("stickslip store check"), std::string::npos) << e.what();
  }
  EXPECT_EQ(file_bytes(db_), bytes) << "the damaged file was written to";
  const StoreCheck check = check_store(db_);
  EXPECT_FALSE(check.ok());
  EXPECT_FALSE(check.problems.empty());
  // An undamaged store passes both checks.
  const fs::path good = tmp_.path() / "good.db";
  { auto store = Store::open(good); }
  EXPECT_TRUE(check_store(good).ok());
}

TEST_F(StoreJobs, ABusyStoreDefersCommitsInsteadOfFailingThem) {
  // Another process holding the write lock past the busy timeout failed the batch, and the
  // study with it (issue 18, defect 3). Now add() keeps the runs and tries again later.
  std::string study;
  {
    auto store = Store::open(db_);
    study = new_study(store, "busy", 100);
  }
  auto w = RunWriter::open(db_, WriterOptions{.max_batch = 8, .max_delay = 1h,
                                              .busy_timeout = 20ms});
  Raw other(db_, false);
  other.exec("BEGIN IMMEDIATE");
  for (int i = 0; i < 30; ++i) ASSERT_NO_THROW(w.add(run_of(study, i))) << "run " << i;
  EXPECT_EQ(w.buffered(), 30u);
  try {
    w.flush();
    ADD_FAILURE() << "flush committed under another writer's lock";
  } catch (const StoreError& e) {
    EXPECT_EQ(e.fault(), StoreFault::kBusy) << e.what();
  }
  other.exec("COMMIT");
  EXPECT_EQ(w.flush().inserted, 30u);
  EXPECT_EQ(Raw(db_).text("SELECT count(*) FROM runs"), "30");
}

}  // namespace
