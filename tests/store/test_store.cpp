// Tests of the SQLite store: ids, hashes and states, opening (rejection of foreign files, left
// byte-for-byte unchanged; unwritable paths; the schema version; another process closing the
// store) and study records. Runs and the writer: test_store_runs.cpp; concurrency and crash
// safety: test_store_crash.cpp.
#include "stickslip/store/store.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "store_test_support.h"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using namespace stickslip::store::test_support;

// ---------------------------------------------------------------------------------------------
// Small pieces
// ---------------------------------------------------------------------------------------------

TEST(StoreHelpers, ParamHashIsFnv1a64) {
  using stickslip::store::param_hash;
  EXPECT_EQ(param_hash(""), "cbf29ce484222325");
  EXPECT_EQ(param_hash("a"), "af63dc4c8601ec8c");
  EXPECT_EQ(param_hash("foobar"), "85944171f73967e8");
}

TEST(StoreHelpers, StudyIdsAreShortUniqueAndSortable) {
  const auto a = stickslip::store::new_study_id();
  std::this_thread::sleep_for(2ms);
  const auto b = stickslip::store::new_study_id();
  EXPECT_EQ(a.rfind("st-", 0), 0u);
  EXPECT_EQ(a.size(), 23u);
  EXPECT_LT(a, b);
}

TEST(StoreHelpers, TimestampsAreIso8601Utc) {
  const auto t = stickslip::store::utc_now_iso8601();
  ASSERT_EQ(t.size(), 24u) << t;
  EXPECT_EQ(t[4], '-');
  EXPECT_EQ(t[10], 'T');
  EXPECT_EQ(t[19], '.');
  EXPECT_EQ(t.back(), 'Z');
}

TEST(StoreHelpers, StudyStateRoundTrips) {
  using stickslip::store::parse_study_state;
  for (auto s : {StudyState::kQueued, StudyState::kRunning, StudyState::kSucceeded,
                 StudyState::kFailed, StudyState::kCancelled})
    EXPECT_EQ(parse_study_state(to_string(s)), s);
  EXPECT_FALSE(parse_study_state("done"));
}

// ---------------------------------------------------------------------------------------------
// Opening
// ---------------------------------------------------------------------------------------------

TEST_F(StoreTest, NewDatabaseIsInitialisedInWalMode) {
  { auto store = Store::open(db_); }
  RawDb raw(db_);
  EXPECT_EQ(raw.integer("PRAGMA application_id"), stickslip::store::kStoreApplicationId);
  EXPECT_EQ(raw.text("PRAGMA journal_mode"), "wal");
  EXPECT_EQ(raw.text("SELECT value FROM meta WHERE key = 'schema_version'"),
            std::to_string(stickslip::store::kStoreSchemaVersion));
  for (const char* name : {"studies", "runs", "stage_metrics", "traces", "v_run_metrics", "v_map",
                           "v_study_progress"})
    EXPECT_EQ(raw.integer(std::string("SELECT count(*) FROM sqlite_master WHERE name = '") +
                          name + "'"),
              1)
        << name;
  // Opening again (read-write and read-only) works and keeps the data.
  { auto store = Store::open(db_); }
  auto ro = Store::open(db_, Store::Mode::kReadOnly);
  EXPECT_TRUE(ro.list_studies(10).empty());
}

TEST_F(StoreTest, EmptyExistingFileIsInitialised) {
  std::ofstream(db_).close();
  ASSERT_EQ(fs::file_size(db_), 0u);
  auto store = Store::open(db_);
  EXPECT_TRUE(store.create_study(new_study("x", 1)).created);
  RawDb raw(db_);
  EXPECT_EQ(raw.integer("PRAGMA application_id"), stickslip::store::kStoreApplicationId);
}

TEST_F(StoreTest, RandomBytesFileIsRejectedUnchanged) {
  std::mt19937_64 rng(42);
  std::string bytes(4096, '\0');
  for (auto& c : bytes) c = static_cast<char>(rng());
  std::ofstream(db_, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  for (auto mode : {Store::Mode::kReadWriteCreate, Store::Mode::kReadOnly})
    expect_store_error([&] { Store::open(db_, mode); }, {db_.string(), "not a stickslip database"});
  expect_store_error([&] { RunWriter::open(db_); }, {db_.string(), "not a stickslip database"});
  EXPECT_EQ(file_bytes(db_), bytes);
  EXPECT_FALSE(fs::exists(db_.string() + "-wal"));
  EXPECT_FALSE(fs::exists(db_.string() + "-journal"));
}

TEST_F(StoreTest, ForeignSqliteDatabaseIsRejectedUnchanged) {
  {
    RawDb other(db_);
    other.exec("CREATE TABLE songs (title TEXT, year INTEGER)");
    other.exec("INSERT INTO songs VALUES ('a', 1999), ('b', 2001)");
  }
  const std::string before = file_bytes(db_);
  ASSERT_FALSE(before.empty());
  for (auto mode : {Store::Mode::kReadWriteCreate, Store::Mode::kReadOnly})
    expect_store_error([&] { Store::open(db_, mode); },
                       {db_.string(), "not a stickslip database", "application_id"});
  expect_store_error([&] { RunWriter::open(db_); }, {db_.string(), "not a stickslip database"});
  EXPECT_EQ(file_bytes(db_), before);
  EXPECT_FALSE(fs::exists(db_.string() + "-wal"));
}

TEST_F(StoreTest, OtherApplicationIdIsRejectedEvenWithoutTables) {
  {
    RawDb other(db_);
    other.exec("PRAGMA application_id = 1234");
  }
  const std::string before = file_bytes(db_);
  expect_store_error([&] { Store::open(db_); }, {db_.string(), "not a stickslip database"});
  EXPECT_EQ(file_bytes(db_), before);
}

TEST_F(StoreTest, ForeignDatabaseWithHotJournalIsNotRecovered) {
  // Another application is killed mid-transaction after spilling pages into its database file:
  // SQLite would roll the hot journal back on the first read. We must reject without that.
  {
    RawDb other(db_);
    other.exec("PRAGMA application_id = 1234");
    other.exec("PRAGMA journal_mode = DELETE");
    other.exec("PRAGMA synchronous = OFF");  // no fsyncs: keeps the test fast
    other.exec("CREATE TABLE blobs (b BLOB)");
    other.exec("WITH RECURSIVE n(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM n WHERE i < 200) "
               "INSERT INTO blobs SELECT zeroblob(2000) FROM n");
  }
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    close(fds[0]);
    try {
      RawDb other(db_);
      other.exec("PRAGMA cache_size = 5");
      other.exec("PRAGMA synchronous = OFF");
      other.exec("BEGIN");
      other.exec("UPDATE blobs SET b = randomblob(2000)");  // spills into the file
      const char ready = 'r';
      if (write(fds[1], &ready, 1) != 1) _exit(2);
      pause();
    } catch (...) {
      _exit(3);
    }
    _exit(4);
  }
  close(fds[1]);
  char ready = 0;
  ASSERT_EQ(read(fds[0], &ready, 1), 1);
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  close(fds[0]);
  const fs::path journal = db_.string() + "-journal";
  ASSERT_TRUE(fs::exists(journal) && fs::file_size(journal) > 0) << "no hot journal was left";
  const std::string db_before = file_bytes(db_), journal_before = file_bytes(journal);
  for (auto mode : {Store::Mode::kReadWriteCreate, Store::Mode::kReadOnly})
    expect_store_error([&] { Store::open(db_, mode); },
                       {db_.string(), "not a stickslip database", "0x000004d2"});
  EXPECT_EQ(file_bytes(db_), db_before);
  EXPECT_EQ(file_bytes(journal), journal_before);
}

/// Output of `sqlite3 <db> <sql>`, a separate process with its own connection (trailing
/// newline removed).
std::string sqlite3_shell(const fs::path& db, const std::string& sql) {
  const std::string cmd = "sqlite3 '" + db.string() + "' '" + sql + "' 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) throw std::runtime_error("popen failed: " + cmd);
  std::string out;
  char buf[256];
  while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
  pclose(p);
  while (!out.empty() && out.back() == '\n') out.pop_back();
  return out;
}

TEST_F(StoreTest, AnotherProcessClosingTheStoreLosesNoCommit) {
  // Opening a second Store or RunWriter must not drop the POSIX locks that the first connection
  // holds (closing ANY descriptor of the file drops every lock of the process: SQLite, "How To
  // Corrupt An SQLite Database File", 2.2). When they were dropped, the next connection of
  // another process to close believed it was the last one, deleted the live -wal and -shm, and
  // every later commit of this process went to an unlinked WAL.
  if (std::system("command -v sqlite3 >/dev/null 2>&1") != 0) GTEST_SKIP() << "no sqlite3 shell";
  auto a = Store::open(db_);
  a.create_study(new_study("first", 1));
  { auto b = Store::open(db_); }
  { auto r = Store::open(db_, Store::Mode::kReadOnly); }
  { auto w = RunWriter::open(db_); }
  ASSERT_EQ(sqlite3_shell(db_, "SELECT count(*) FROM studies"), "1");
  EXPECT_TRUE(fs::exists(db_.string() + "-wal")) << "the live WAL was deleted";
  const std::string second = a.create_study(new_study("second", 2)).study.id;
  auto w = RunWriter::open(db_);
  w.add(simple_run(second, 0));
  w.flush();
  EXPECT_EQ(sqlite3_shell(db_, "SELECT count(*) FROM studies"), "2");
  EXPECT_EQ(sqlite3_shell(db_, "SELECT count(*) FROM runs"), "1");
  EXPECT_EQ(sqlite3_shell(db_, "PRAGMA integrity_check"), "ok");
}

TEST_F(StoreTest, NewerSchemaVersionIsRejected) {
  { auto store = Store::open(db_); }
  {
    RawDb raw(db_);
    raw.exec("UPDATE meta SET value = '99' WHERE key = 'schema_version'");
  }
  expect_store_error([&] { Store::open(db_); }, {db_.string(), "schema_version 99"});
}

TEST_F(StoreTest, UnwritableOrMissingPathsAreReported) {
  // Tests may run as root, so permissions cannot stop them: use paths no one can create.
  for (const fs::path& p : {fs::path("/proc/nonexistent/x.db"), fs::path("/proc/x.db"),
                           dir_ / "no-such-dir" / "x.db"}) {
    SCOPED_TRACE(p.string());
    expect_store_error([&] { Store::open(p); }, {p.string()});
    expect_store_error([&] { RunWriter::open(p); }, {p.string()});
    EXPECT_FALSE(fs::exists(p));
  }
  const fs::path missing = dir_ / "missing.db";
  expect_store_error([&] { Store::open(missing, Store::Mode::kReadOnly); }, {missing.string()});
  EXPECT_FALSE(fs::exists(missing));
  // A directory is not a database either.
  expect_store_error([&] { Store::open(dir_); }, {dir_.string()});
}

TEST_F(StoreTest, ReadOnlyStoreRefusesWrites) {
  make_study(1);
  auto ro = Store::open(db_, Store::Mode::kReadOnly);
  expect_store_error([&] { ro.create_study(new_study("y", 1)); }, {db_.string(), "readonly"});
}

// ---------------------------------------------------------------------------------------------
// Studies
// ---------------------------------------------------------------------------------------------

TEST_F(StoreTest, CreateGetAndSetStudyState) {
  auto store = Store::open(db_);
  NewStudy ns = new_study("sweep", 12);
  const CreatedStudy c = store.create_study(ns);
  ASSERT_TRUE(c.created);
  EXPECT_EQ(c.study.id.rfind("st-", 0), 0u);
  EXPECT_EQ(c.study.name, "sweep");
  EXPECT_EQ(c.study.spec_json, ns.spec_json);
  EXPECT_EQ(c.study.spec_hash, ns.spec_hash);
  EXPECT_EQ(c.study.total_runs, 12);
  EXPECT_EQ(c.study.state, StudyState::kQueued);
  EXPECT_EQ(c.study.created_at.size(), 24u);
  EXPECT_FALSE(c.study.started_at || c.study.finished_at || c.study.error);

  store.set_study_state(c.study.id, StudyState::kRunning);
  auto s = store.get_study(c.study.id);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, StudyState::kRunning);
  ASSERT_TRUE(s->started_at);
  EXPECT_FALSE(s->finished_at);
  const std::string started = *s->started_at;

  store.set_study_state(c.study.id, StudyState::kFailed, "engine exploded");
  s = store.get_study(c.study.id);
  EXPECT_EQ(s->state, StudyState::kFailed);
  EXPECT_EQ(s->error, "engine exploded");
  EXPECT_TRUE(s->finished_at);
  EXPECT_EQ(s->started_at, started);

  store.set_study_state(c.study.id, StudyState::kRunning);  // resumed
  s = store.get_study(c.study.id);
  EXPECT_EQ(s->started_at, started);
  EXPECT_FALSE(s->finished_at);
  EXPECT_FALSE(s->error);

  EXPECT_FALSE(store.get_study("st-nope"));
  expect_store_error([&] { store.set_study_state("st-nope", StudyState::kRunning); },
                     {"st-nope", "no such study"});

  // A study that grows (a Sobol design with "until"): more runs, never fewer.
  store.extend_study(c.study.id, 24);
  EXPECT_EQ(store.get_study(c.study.id)->total_runs, 24);
  EXPECT_EQ(store.count_runs(c.study.id).total, 24);
  expect_store_error([&] { store.extend_study(c.study.id, 12); }, {c.study.id, "fewer than the 24"});
  EXPECT_EQ(store.get_study(c.study.id)->total_runs, 24);
  expect_store_error([&] { store.extend_study("st-nope", 30); }, {"st-nope", "no such study"});
}

TEST_F(StoreTest, CreateStudyRejectsDuplicateIdAndBadSpec) {
  auto store = Store::open(db_);
  NewStudy ns = new_study("a", 1);
  ns.id = "st-fixed";
  EXPECT_EQ(store.create_study(ns).study.id, "st-fixed");
  expect_store_error([&] { store.create_study(ns); }, {"st-fixed", "already exists"});
  NewStudy bad = new_study("b", 1);
  bad.spec_json = "{not json";
  expect_store_error([&] { store.create_study(bad); }, {"not JSON"});
  EXPECT_EQ(store.list_studies(10).size(), 1u);
}

TEST_F(StoreTest, IdempotencyKeyReturnsTheStoredStudy) {
  auto store = Store::open(db_);
  NewStudy ns = new_study("a", 3);
  ns.idempotency_key = "key-1";
  ns.request_hash = "rh-1";
  const auto first = store.create_study(ns);
  ASSERT_TRUE(first.created);
  NewStudy again = new_study("a-retry", 3);
  again.idempotency_key = "key-1";
  again.request_hash = "rh-2";
  const auto second = store.create_study(again);
  EXPECT_FALSE(second.created);
  EXPECT_EQ(second.study.id, first.study.id);
  EXPECT_EQ(second.study.request_hash, "rh-1");
  const auto found = store.find_by_idempotency_key("key-1");
  ASSERT_TRUE(found);
  EXPECT_EQ(found->id, first.study.id);
  EXPECT_FALSE(store.find_by_idempotency_key("key-2"));
  EXPECT_EQ(store.list_studies(10).size(), 1u);
}

TEST_F(StoreTest, ListStudiesPaginates) {
  auto store = Store::open(db_);
  std::vector<std::string> ids;
  for (int i = 0; i < 5; ++i) ids.push_back(store.create_study(new_study("s", 1)).study.id);
  std::sort(ids.begin(), ids.end());
  std::vector<std::string> seen;
  std::string after;
  for (int page = 0; page < 10; ++page) {
    const auto rows = store.list_studies(2, after);
    if (rows.empty()) break;
    EXPECT_LE(rows.size(), 2u);
    for (const auto& r : rows) seen.push_back(r.id);
    after = rows.back().id;
  }
  EXPECT_EQ(seen, ids);
}

TEST_F(StoreTest, ListStudiesFiltersByNameCaseInsensitivelyWithoutWildcards) {
  auto store = Store::open(db_);
  for (const char* name : {"paper-map", "Load", "MAP_2", "other", "50%"})
    store.create_study(new_study(name, 1));
  std::vector<std::string> names;
  std::string after;
  for (int page = 0; page < 10; ++page) {
    const auto rows = store.list_studies(1, after, "map");
    if (rows.empty()) break;
    names.push_back(rows[0].name);
    after = rows[0].id;
  }
  std::sort(names.begin(), names.end());  // ids of the same millisecond sort by chance
  EXPECT_EQ(names, (std::vector<std::string>{"MAP_2", "paper-map"}));
  EXPECT_EQ(store.list_studies(10, "", "%").size(), 1u);  // the literal '%', not "anything"
  EXPECT_EQ(store.list_studies(10, "", "_").size(), 1u);
  EXPECT_EQ(store.list_studies(10, "", "").size(), 5u);
}

}  // namespace
