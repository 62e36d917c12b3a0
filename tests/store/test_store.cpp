// Tests of the SQLite store: studies, batched run writes, exact read-back, views, idempotent
// re-adds, rejection of foreign files (left byte-for-byte unchanged), unwritable paths, crash
// safety under a real SIGKILL, and WAL reader/writer concurrency.
#include "stickslip/store/store.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
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

std::string file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::uint64_t bits(double d) { return std::bit_cast<std::uint64_t>(d); }

#define EXPECT_SAME_DOUBLE(a, b) EXPECT_EQ(bits(a), bits(b)) << (a) << " vs " << (b)

void expect_same_opt(const std::optional<double>& a, const std::optional<double>& b) {
  ASSERT_EQ(a.has_value(), b.has_value());
  if (a) {
    EXPECT_SAME_DOUBLE(*a, *b);
  }
}

/// Any double except NaN (stored as NULL) and -0.0 (read back as +0.0; see store.h).
double random_double(std::mt19937_64& rng) {
  for (;;) {
    const double d = std::bit_cast<double>(rng());
    if (!std::isnan(d) && !(d == 0.0 && std::signbit(d))) return d;
  }
}

double pick_double(std::mt19937_64& rng) {
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

StageMetricsRecord random_stage(std::mt19937_64& rng, int stage) {
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

std::vector<TracePoint> random_trace(std::mt19937_64& rng, std::size_t n) {
  std::vector<TracePoint> trace(n);
  for (auto& p : trace)
    p = {pick_double(rng), pick_double(rng), pick_double(rng), pick_double(rng), pick_double(rng),
         pick_double(rng)};
  return trace;
}

/// Run i of the 1000-run study: every 7th from 3 is invalid (no stages), every 7th from 5
/// diverged (1 stage), the rest ok (2 stages); two models; va_over_vd NULL for i % 11 == 0.
RunRecord random_run(const std::string& study, std::int64_t i, std::mt19937_64& rng) {
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

void expect_same_run(const RunRecord& want, const RunRecord& got) {
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
RunRecord simple_run(const std::string& study, std::int64_t i, const std::string& hash = "") {
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

NewStudy new_study(const std::string& name, std::int64_t total_runs) {
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
void expect_store_error(Fn&& fn, const std::vector<std::string>& needles) {
  try {
    fn();
    ADD_FAILURE() << "no StoreError thrown";
  } catch (const StoreError& e) {
    for (const auto& n : needles)
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos)
          << "message '" << e.what() << "' lacks '" << n << "'";
  }
}

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

// ---------------------------------------------------------------------------------------------
// Runs
// ---------------------------------------------------------------------------------------------

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
  for (const auto& w : want) {
    const auto trace = store.get_trace(study, w.design_index);
    ASSERT_EQ(trace.has_value(), !w.trace.empty()) << w.design_index;
    if (!trace) continue;
    ++n_traces;
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
  EXPECT_EQ(n_traces, 100);

  // Counts and views, with expectations computed from the generated records.
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

  RawDb raw(db_);
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

// ---------------------------------------------------------------------------------------------
// Concurrency and crash safety
// ---------------------------------------------------------------------------------------------

TEST_F(StoreTest, WalReadersAndWriterDoNotBlockEachOther) {
  const std::string study = make_study(100);
  auto writer = RunWriter::open(db_, WriterOptions{.busy_timeout = 3000ms});
  for (int i = 0; i < 10; ++i) writer.add(simple_run(study, i));
  writer.flush();

  // Another connection holds an open write transaction with an uncommitted run.
  RawDb other_writer(db_);
  other_writer.exec("BEGIN IMMEDIATE");
  other_writer.exec("INSERT INTO runs (study_id, design_index, param_hash, params_json, status, "
                    "steps, finished_at) VALUES ('" + study + "', 50, 'h', '{}', 'ok', 0, 'now')");
  auto reader = Store::open(db_, Store::Mode::kReadOnly, 3000ms);
  auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(reader.count_runs(study).done, 10);  // the last committed snapshot
  EXPECT_EQ(reader.get_runs(study).size(), 10u);
  EXPECT_EQ(reader.completed_design_indices(study).size(), 10u);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1000ms) << "reader waited for the writer";
  other_writer.exec("COMMIT");
  EXPECT_EQ(reader.count_runs(study).done, 11);

  // A reader in the middle of a read transaction does not block the writer's commit.
  RawDb long_reader(db_);
  long_reader.exec("BEGIN");
  EXPECT_EQ(long_reader.integer("SELECT count(*) FROM runs"), 11);
  for (int i = 10; i < 15; ++i) writer.add(simple_run(study, i));
  t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(writer.flush().inserted, 5u);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1000ms) << "writer waited for the reader";
  EXPECT_EQ(long_reader.integer("SELECT count(*) FROM runs"), 11);  // its snapshot
  long_reader.exec("COMMIT");
  EXPECT_EQ(long_reader.integer("SELECT count(*) FROM runs"), 16);
}

constexpr std::size_t kCrashBatch = 40;

/// The child: writes runs forever in batches of kCrashBatch and reports the highest committed
/// design index on fd after every commit. Only async-safe exits; no gtest.
[[noreturn]] void crash_child(const fs::path& db, const std::string& study, int fd) {
  try {
    auto writer = RunWriter::open(db, WriterOptions{.max_batch = kCrashBatch, .max_delay = 1h});
    const auto deadline = std::chrono::steady_clock::now() + 15s;
    for (std::int64_t i = 0;; ++i) {
      writer.add(simple_run(study, i));
      if (writer.buffered() == 0 && write(fd, &i, sizeof i) != sizeof i) _exit(4);
      if (std::chrono::steady_clock::now() > deadline) _exit(3);
    }
  } catch (...) {
    _exit(2);
  }
}

/// Reads one committed index from the child; false at EOF.
bool read_report(int fd, std::int64_t& index) {
  std::size_t got = 0;
  auto* p = reinterpret_cast<char*>(&index);
  while (got < sizeof index) {
    const ssize_t n = read(fd, p + got, sizeof index - got);
    if (n == 0) return false;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return false;
    got += static_cast<std::size_t>(n);
  }
  return true;
}

void verify_after_crash(const fs::path& db, const std::string& study, std::int64_t max_reported) {
  RawDb raw(db);
  EXPECT_EQ(raw.text("PRAGMA integrity_check"), "ok");
  EXPECT_TRUE(raw.rows("PRAGMA foreign_key_check").empty());
  const std::int64_t n = raw.integer("SELECT count(*) FROM runs");
  EXPECT_GE(n, max_reported + 1);
  EXPECT_EQ(n % static_cast<std::int64_t>(kCrashBatch), 0) << "a batch was committed in part";
  EXPECT_EQ(raw.integer("SELECT count(DISTINCT design_index) FROM runs"), n);
  EXPECT_EQ(raw.integer("SELECT max(design_index) FROM runs"), n - 1);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM runs WHERE design_index <= " +
                        std::to_string(max_reported)),
            max_reported + 1);
  // No partial run: every run has its 3 stages (and its trace when due), nothing is orphaned.
  EXPECT_EQ(raw.integer("SELECT count(*) FROM runs AS r WHERE (SELECT count(*) FROM stage_metrics "
                        "AS m WHERE m.study_id = r.study_id AND m.design_index = r.design_index) "
                        "<> 3"),
            0);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM stage_metrics AS m WHERE NOT EXISTS (SELECT 1 FROM "
                        "runs AS r WHERE r.study_id = m.study_id AND r.design_index = "
                        "m.design_index)"),
            0);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM traces"), (n + 3) / 4);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM traces AS t WHERE NOT EXISTS (SELECT 1 FROM runs "
                        "AS r WHERE r.study_id = t.study_id AND r.design_index = t.design_index)"),
            0);
  (void)study;
}

TEST_F(StoreTest, SigkillNeverLosesCommittedRunsNorLeavesPartialOnes) {
  std::mt19937_64 rng(2024);
  for (int rep = 0; rep < 5; ++rep) {
    SCOPED_TRACE("repetition " + std::to_string(rep));
    const fs::path db = dir_ / ("crash-" + std::to_string(rep) + ".db");
    const std::string study = make_study(1'000'000, db);  // closed again before fork

    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      close(fds[0]);
      crash_child(db, study, fds[1]);
    }
    close(fds[1]);
    std::int64_t max_reported = -1, index = 0;
    const int wanted = 1 + rep % 3;
    for (int k = 0; k < wanted; ++k) {
      if (!read_report(fds[0], index)) break;
      max_reported = index;
    }
    // Kill at an arbitrary moment: during an add, inside a commit, or between batches.
    std::this_thread::sleep_for(std::chrono::microseconds(rng() % 3000));
    kill(pid, SIGKILL);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    while (read_report(fds[0], index)) max_reported = index;  // reports sent before death
    close(fds[0]);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
        << "child exited early with status " << (WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    ASSERT_GE(max_reported, static_cast<std::int64_t>(kCrashBatch) - 1) << "no commit reported";

    verify_after_crash(db, study, max_reported);

    // Resume: the store opens, reports what is done, and re-adding never duplicates.
    auto store = Store::open(db);
    const auto done = store.completed_design_indices(study);
    const auto n = static_cast<std::int64_t>(done.size());
    for (std::int64_t i = 0; i < n; ++i) ASSERT_EQ(done[static_cast<std::size_t>(i)], i);
    auto writer = RunWriter::open(db, WriterOptions{.max_batch = 100000});
    for (std::int64_t i = 0; i < n + 7; ++i) writer.add(simple_run(study, i));
    const FlushResult f = writer.flush();
    EXPECT_EQ(f.duplicates, static_cast<std::size_t>(n));
    EXPECT_EQ(f.inserted, 7u);
    EXPECT_EQ(store.count_runs(study).done, n + 7);
  }
}

}  // namespace
