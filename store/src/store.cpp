// The SQLite store for studies and runs. Schema: kSchemaSql below, documented in docs/store.md.
//
// Layout of this file: error helpers, a thin RAII layer over sqlite3 (Connection, Statement,
// Transaction), opening/validating/initialising a database, row <-> record conversion, then
// Store and RunWriter.
#include "stickslip/store/store.h"

#include <sqlite3.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <limits>
#include <random>
#include <utility>

#include <nlohmann/json.hpp>

namespace stickslip::store {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Schema (version kStoreSchemaVersion). Keep docs/store.md in step with this text.
// ---------------------------------------------------------------------------------------------

constexpr const char* kSchemaSql = R"sql(
CREATE TABLE meta (
  key   TEXT PRIMARY KEY NOT NULL,
  value TEXT NOT NULL
);

CREATE TABLE studies (
  id              TEXT PRIMARY KEY NOT NULL,
  name            TEXT NOT NULL,
  spec_json       TEXT NOT NULL,
  spec_hash       TEXT NOT NULL,
  state           TEXT NOT NULL DEFAULT 'queued'
                  CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  total_runs      INTEGER NOT NULL CHECK (total_runs >= 0),
  created_at      TEXT NOT NULL,
  started_at      TEXT,
  finished_at     TEXT,
  error           TEXT,
  idempotency_key TEXT UNIQUE,
  request_hash    TEXT
);

CREATE TABLE runs (
  study_id     TEXT NOT NULL REFERENCES studies (id) ON DELETE CASCADE,
  design_index INTEGER NOT NULL CHECK (design_index >= 0),
  param_hash   TEXT NOT NULL,
  params_json  TEXT NOT NULL,
  model        TEXT,
  va_over_vd   REAL,
  status       TEXT NOT NULL CHECK (status IN ('ok', 'diverged', 'invalid')),
  error        TEXT,
  wall_time_s  REAL,
  t_end        REAL,
  steps        INTEGER NOT NULL,
  rmse         REAL,
  finished_at  TEXT NOT NULL,
  PRIMARY KEY (study_id, design_index)
);
CREATE INDEX runs_study_model_va ON runs (study_id, model, va_over_vd);
CREATE INDEX runs_va_over_vd ON runs (va_over_vd);
CREATE INDEX runs_study_status ON runs (study_id, status);
CREATE INDEX runs_param_hash ON runs (param_hash);

CREATE TABLE stage_metrics (
  study_id      TEXT NOT NULL,
  design_index  INTEGER NOT NULL,
  stage         INTEGER NOT NULL CHECK (stage >= 1),
  t_start       REAL,
  t_end         REAL,
  amplitude     REAL,
  amplitude_raw REAL,
  mean_force    REAL,
  mean_friction REAL,
  slip_events   INTEGER NOT NULL,
  mean_period   REAL,
  rmse          REAL,
  PRIMARY KEY (study_id, design_index, stage),
  FOREIGN KEY (study_id, design_index) REFERENCES runs (study_id, design_index)
    ON DELETE CASCADE
);

CREATE TABLE traces (
  study_id     TEXT NOT NULL,
  design_index INTEGER NOT NULL,
  n_samples    INTEGER NOT NULL CHECK (n_samples > 0),
  t            BLOB NOT NULL CHECK (length(t) = 8 * n_samples),
  F_d          BLOB NOT NULL CHECK (length(F_d) = 8 * n_samples),
  F_f          BLOB NOT NULL CHECK (length(F_f) = 8 * n_samples),
  x            BLOB NOT NULL CHECK (length(x) = 8 * n_samples),
  v            BLOB NOT NULL CHECK (length(v) = 8 * n_samples),
  s            BLOB NOT NULL CHECK (length(s) = 8 * n_samples),
  PRIMARY KEY (study_id, design_index),
  FOREIGN KEY (study_id, design_index) REFERENCES runs (study_id, design_index)
    ON DELETE CASCADE
);

CREATE VIEW v_run_metrics AS
SELECT r.study_id, r.design_index, r.model, r.va_over_vd, r.status, r.error, r.param_hash,
       r.params_json, r.wall_time_s, r.t_end AS run_t_end, r.steps, r.rmse AS run_rmse,
       m.stage, m.t_start, m.t_end, m.amplitude, m.amplitude_raw, m.mean_force,
       m.mean_friction, m.slip_events, m.mean_period, m.rmse
FROM runs AS r
LEFT JOIN stage_metrics AS m
  ON m.study_id = r.study_id AND m.design_index = r.design_index;

CREATE VIEW v_map AS
SELECT study_id, design_index, model, va_over_vd, stage, amplitude, mean_force, status
FROM v_run_metrics;

CREATE VIEW v_study_progress AS
SELECT s.id AS study_id, s.state, s.total_runs AS total,
       COUNT(r.design_index) AS done,
       COALESCE(SUM(r.status = 'ok'), 0) AS ok,
       COALESCE(SUM(r.status <> 'ok'), 0) AS failed
FROM studies AS s
LEFT JOIN runs AS r ON r.study_id = s.id
GROUP BY s.id;
)sql";

// Added in schema version 2 (a version-1 database gets it by migrate_step on its first
// read-write open). A diagnosis is one job: the request (manifest + CSV contents) in, the
// diagnosis.json document out.
constexpr const char* kDiagnosesSql = R"sql(
CREATE TABLE diagnoses (
  id              TEXT PRIMARY KEY NOT NULL,
  name            TEXT NOT NULL,
  request_json    TEXT NOT NULL,
  request_hash    TEXT NOT NULL,
  state           TEXT NOT NULL DEFAULT 'queued'
                  CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  created_at      TEXT NOT NULL,
  started_at      TEXT,
  finished_at     TEXT,
  error           TEXT,
  result_json     TEXT,
  idempotency_key TEXT UNIQUE
);
CREATE INDEX diagnoses_state ON diagnoses (state);
)sql";

// Added in schema version 3 (a version-2 database gets it by migrate_to_3; a new database runs
// the same statements, so a migrated file and a new one have the same schema). Each study row
// carries its run counters, kept by triggers in the transaction that writes or removes a run, so
// that v_study_progress (polled by every GET /v1/studies/{id}) reads one row instead of
// scanning all the study's runs: 1.9 ms for 3072 runs, growing linearly, with the version-2
// aggregate view (measured 2026-11-22).
constexpr const char* kRunCountersSql = R"sql(
ALTER TABLE studies ADD COLUMN runs_done INTEGER NOT NULL DEFAULT 0 CHECK (runs_done >= 0);
ALTER TABLE studies ADD COLUMN runs_ok INTEGER NOT NULL DEFAULT 0 CHECK (runs_ok >= 0);
ALTER TABLE studies ADD COLUMN runs_failed INTEGER NOT NULL DEFAULT 0 CHECK (runs_failed >= 0);
UPDATE studies SET
  runs_done = (SELECT COUNT(*) FROM runs WHERE runs.study_id = studies.id),
  runs_ok = (SELECT COUNT(*) FROM runs WHERE runs.study_id = studies.id AND runs.status = 'ok'),
  runs_failed = (SELECT COUNT(*) FROM runs WHERE runs.study_id = studies.id AND runs.status <> 'ok');

CREATE TRIGGER runs_count_insert AFTER INSERT ON runs BEGIN
  UPDATE studies SET runs_done = runs_done + 1,
                     runs_ok = runs_ok + (NEW.status = 'ok'),
                     runs_failed = runs_failed + (NEW.status <> 'ok')
  WHERE id = NEW.study_id;
END;
CREATE TRIGGER runs_count_delete AFTER DELETE ON runs BEGIN
  UPDATE studies SET runs_done = runs_done - 1,
                     runs_ok = runs_ok - (OLD.status = 'ok'),
                     runs_failed = runs_failed - (OLD.status <> 'ok')
  WHERE id = OLD.study_id;
END;
CREATE TRIGGER runs_count_update AFTER UPDATE OF study_id, status ON runs BEGIN
  UPDATE studies SET runs_done = runs_done - 1,
                     runs_ok = runs_ok - (OLD.status = 'ok'),
                     runs_failed = runs_failed - (OLD.status <> 'ok')
  WHERE id = OLD.study_id;
  UPDATE studies SET runs_done = runs_done + 1,
                     runs_ok = runs_ok + (NEW.status = 'ok'),
                     runs_failed = runs_failed + (NEW.status <> 'ok')
  WHERE id = NEW.study_id;
END;

DROP VIEW v_study_progress;
CREATE VIEW v_study_progress AS
SELECT id AS study_id, state, total_runs AS total, runs_done AS done, runs_ok AS ok,
       runs_failed AS failed
FROM studies;
)sql";

// ---------------------------------------------------------------------------------------------
// Errors
// ---------------------------------------------------------------------------------------------

std::string where(const fs::path& path) { return "stickslip store '" + path.string() + "'"; }

[[noreturn]] void fail(const fs::path& path, std::string_view what) {
  throw StoreError(where(path) + ": " + std::string(what));
}

/// An SQLite error; keeps the extended result code so that the writer can tell a constraint
/// violation of one run from a failure of the whole transaction.
class SqliteError : public StoreError {
 public:
  SqliteError(const std::string& message, int code) : StoreError(message), code_(code) {}
  int code() const noexcept { return code_; }
  bool is_constraint() const noexcept { return (code_ & 0xff) == SQLITE_CONSTRAINT; }

 private:
  int code_;
};

SqliteError sqlite_error(const fs::path& path, sqlite3* db, std::string_view doing, int rc) {
  const int ext = db != nullptr ? sqlite3_extended_errcode(db) : rc;
  const char* msg = db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
  return SqliteError(where(path) + ": " + std::string(doing) + ": " + msg + " (SQLite code " +
                         std::to_string(ext) + ", " + sqlite3_errstr(ext) + ")",
                     ext);
}

[[noreturn]] void fail_sqlite(const fs::path& path, sqlite3* db, std::string_view doing, int rc) {
  throw sqlite_error(path, db, doing, rc);
}

// ---------------------------------------------------------------------------------------------
// RAII over sqlite3
// ---------------------------------------------------------------------------------------------

struct DbClose {
  void operator()(sqlite3* db) const noexcept { sqlite3_close_v2(db); }
};
using DbPtr = std::unique_ptr<sqlite3, DbClose>;

struct StmtFinalize {
  void operator()(sqlite3_stmt* s) const noexcept { sqlite3_finalize(s); }
};
using StmtPtr = std::unique_ptr<sqlite3_stmt, StmtFinalize>;

class Statement;

class Connection {
 public:
  Connection(fs::path path, DbPtr db) : path_(std::move(path)), db_(std::move(db)) {}
  sqlite3* get() const noexcept { return db_.get(); }
  const fs::path& path() const noexcept { return path_; }
  [[noreturn]] void fail(std::string_view doing, int rc) const {
    fail_sqlite(path_, db_.get(), doing, rc);
  }
  void exec(const char* sql, std::string_view doing) const {
    const int rc = sqlite3_exec(db_.get(), sql, nullptr, nullptr, nullptr);
    if (rc != SQLITE_OK) fail(doing, rc);
  }
  /// exec for cleanup paths: never throws.
  void exec_noexcept(const char* sql) const noexcept {
    sqlite3_exec(db_.get(), sql, nullptr, nullptr, nullptr);
  }
  std::int64_t changes() const noexcept { return sqlite3_changes(db_.get()); }

 private:
  fs::path path_;
  DbPtr db_;
};

/// A prepared statement. Binding indices are 1-based, column indices 0-based (as in SQLite).
class Statement {
 public:
  Statement(const Connection& conn, const char* sql, std::string doing, bool persistent = false)
      : conn_(&conn), doing_(std::move(doing)) {
    sqlite3_stmt* raw = nullptr;
    const unsigned flags = persistent ? SQLITE_PREPARE_PERSISTENT : 0;
    const int rc = sqlite3_prepare_v3(conn.get(), sql, -1, flags, &raw, nullptr);
    stmt_.reset(raw);
    if (rc != SQLITE_OK) conn.fail("preparing statement for " + doing_, rc);
  }

  /// Resets for reuse and clears all bindings.
  Statement& reset() noexcept {
    sqlite3_reset(stmt_.get());
    sqlite3_clear_bindings(stmt_.get());
    return *this;
  }
  Statement& bind_int(int i, std::int64_t v) { return check(sqlite3_bind_int64(stmt_.get(), i, v)); }
  /// NaN is stored as NULL (SQLite has no NaN).
  Statement& bind_real(int i, double v) { return check(sqlite3_bind_double(stmt_.get(), i, v)); }
  Statement& bind_real(int i, const std::optional<double>& v) {
    return v ? bind_real(i, *v) : bind_null(i);
  }
  Statement& bind_text(int i, std::string_view v) {
    return check(sqlite3_bind_text64(stmt_.get(), i, v.data(), v.size(), SQLITE_TRANSIENT,
                                     SQLITE_UTF8));
  }
  Statement& bind_opt_text(int i, const std::optional<std::string>& v) {
    return v ? bind_text(i, std::string_view(*v)) : bind_null(i);
  }
  Statement& bind_blob(int i, const std::vector<unsigned char>& v) {
    return check(sqlite3_bind_blob64(stmt_.get(), i, v.data(), v.size(), SQLITE_TRANSIENT));
  }
  Statement& bind_null(int i) { return check(sqlite3_bind_null(stmt_.get(), i)); }

  /// true: a row is available; false: done. Throws SqliteError otherwise.
  bool step() {
    const int rc = sqlite3_step(stmt_.get());
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    SqliteError error = sqlite_error(conn_->path(), conn_->get(), doing_, rc);
    sqlite3_reset(stmt_.get());  // a failed statement must not stay pending (COMMIT would fail)
    throw error;
  }
  /// Steps to completion (for statements returning no rows of interest), then resets.
  void run() {
    while (step()) {
    }
    sqlite3_reset(stmt_.get());
  }

  bool is_null(int c) const noexcept { return sqlite3_column_type(stmt_.get(), c) == SQLITE_NULL; }
  std::int64_t int64(int c) const noexcept { return sqlite3_column_int64(stmt_.get(), c); }
  /// NULL reads back as a quiet NaN (the inverse of bind_real storing NaN as NULL).
  double real(int c) const noexcept {
    return is_null(c) ? std::numeric_limits<double>::quiet_NaN()
                      : sqlite3_column_double(stmt_.get(), c);
  }
  std::optional<double> opt_real(int c) const noexcept {
    if (is_null(c)) return std::nullopt;
    return sqlite3_column_double(stmt_.get(), c);
  }
  std::string text(int c) const {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(stmt_.get(), c));
    const int n = sqlite3_column_bytes(stmt_.get(), c);
    return p != nullptr ? std::string(p, static_cast<std::size_t>(n)) : std::string();
  }
  std::optional<std::string> opt_text(int c) const {
    if (is_null(c)) return std::nullopt;
    return text(c);
  }
  std::vector<unsigned char> blob(int c) const {
    const auto* p = static_cast<const unsigned char*>(sqlite3_column_blob(stmt_.get(), c));
    const int n = sqlite3_column_bytes(stmt_.get(), c);
    return p != nullptr ? std::vector<unsigned char>(p, p + n) : std::vector<unsigned char>();
  }

 private:
  Statement& check(int rc) {
    if (rc != SQLITE_OK) conn_->fail("binding a parameter for " + doing_, rc);
    return *this;
  }

  const Connection* conn_;
  std::string doing_;
  StmtPtr stmt_;
};

std::int64_t query_int(const Connection& conn, const char* sql, const std::string& doing) {
  Statement st(conn, sql, doing);
  if (!st.step()) fail(conn.path(), "no result when " + std::string(doing));
  return st.int64(0);
}

/// BEGIN IMMEDIATE (write) or BEGIN (read snapshot); rolls back unless committed.
class Transaction {
 public:
  enum class Kind { kRead, kWrite };
  Transaction(const Connection& conn, Kind kind, std::string_view doing) : conn_(conn) {
    conn_.exec(kind == Kind::kWrite ? "BEGIN IMMEDIATE" : "BEGIN",
               "beginning a transaction for " + std::string(doing));
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction() {
    if (!done_) conn_.exec_noexcept("ROLLBACK");
  }
  void commit(std::string_view doing) {
    conn_.exec("COMMIT", "committing " + std::string(doing));
    done_ = true;
  }

 private:
  const Connection& conn_;
  bool done_ = false;
};

// ---------------------------------------------------------------------------------------------
// Opening, validating and initialising a database
// ---------------------------------------------------------------------------------------------

struct DbIdentity {
  std::int64_t application_id = 0;
  std::int64_t schema_objects = 0;
  bool empty() const noexcept { return application_id == 0 && schema_objects == 0; }
  bool ours() const noexcept { return application_id == kStoreApplicationId; }
};

DbIdentity read_identity(const Connection& conn) {
  return {query_int(conn, "PRAGMA application_id", "reading the application_id"),
          query_int(conn, "SELECT count(*) FROM sqlite_master", "reading the schema")};
}

[[noreturn]] void fail_foreign(const fs::path& path, const DbIdentity& id) {
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "not a stickslip database: application_id is 0x%08" PRIx32
                " (expected 0x%08" PRIx32 ")%s; left unchanged",
                static_cast<std::uint32_t>(id.application_id),
                static_cast<std::uint32_t>(kStoreApplicationId),
                id.schema_objects > 0 ? " and it holds tables" : "");
  fail(path, buf);
}

/// The first 100 bytes of path (fewer when the file is shorter), read through SQLite's default
/// VFS and never through a descriptor of our own. Closing ANY descriptor of a database file drops
/// every POSIX lock the process holds on it (SQLite, "How To Corrupt An SQLite Database File",
/// section 2.2): after a plain std::ifstream read here, the next connection of another process
/// to close believed it was the last one, deleted the live -wal and -shm, and this process' later
/// commits went to an unlinked WAL. The VFS's xClose keeps the descriptor open until the
/// process' other connections to the file release their locks.
std::string read_header_via_vfs(const fs::path& path) {
  sqlite3_vfs* vfs = sqlite3_vfs_find(nullptr);
  if (vfs == nullptr) fail(path, "reading the file header: SQLite has no default VFS");
  // A VFS file name is followed by its (here empty) URI parameters: end it with extra NULs.
  std::string name = path.string();
  name.append(4, '\0');
  std::unique_ptr<sqlite3_file, decltype(&sqlite3_free)> file(
      static_cast<sqlite3_file*>(sqlite3_malloc(vfs->szOsFile)), &sqlite3_free);
  if (!file) fail(path, "reading the file header: out of memory");
  std::memset(file.get(), 0, static_cast<std::size_t>(vfs->szOsFile));
  int out_flags = 0;
  int rc = vfs->xOpen(vfs, name.c_str(), file.get(), SQLITE_OPEN_READONLY | SQLITE_OPEN_MAIN_DB,
                      &out_flags);
  if (rc != SQLITE_OK) {
    if (file->pMethods != nullptr) file->pMethods->xClose(file.get());
    return {};  // unreadable: the real open reports it
  }
  std::array<char, 100> header{};
  sqlite3_int64 size = 0;
  rc = file->pMethods->xFileSize(file.get(), &size);
  const int n = rc == SQLITE_OK ? static_cast<int>(std::min<sqlite3_int64>(size, 100)) : 0;
  if (n > 0) rc = file->pMethods->xRead(file.get(), header.data(), n, 0);
  file->pMethods->xClose(file.get());
  if (rc != SQLITE_OK) return {};
  return std::string(header.data(), static_cast<std::size_t>(n));
}

/// Rejects an existing non-empty file that is not an SQLite database, or whose header carries
/// another application_id, before SQLite opens it (so that SQLite never writes to it, e.g. by
/// rolling back a hot journal). Header layout: https://www.sqlite.org/fileformat.html (the magic
/// string at offset 0, the big-endian application_id at offset 68).
void require_sqlite_header(const fs::path& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec || size == 0) return;  // missing, a directory or empty: SQLite decides
  const std::string header = read_header_via_vfs(path);
  if (header.empty()) return;
  constexpr char kMagic[] = "SQLite format 3";  // 15 chars + the terminating NUL = 16 bytes
  if (header.size() < 16 || std::memcmp(header.data(), kMagic, 16) != 0)
    fail(path, "not a stickslip database: the file is not an SQLite database (no SQLite header); "
               "left unchanged");
  if (header.size() < 100) return;
  std::uint32_t app_id = 0;
  for (int k = 68; k < 72; ++k)
    app_id = (app_id << 8) | static_cast<unsigned char>(header[static_cast<std::size_t>(k)]);
  if (app_id != 0 && app_id != static_cast<std::uint32_t>(kStoreApplicationId))
    fail_foreign(path, {static_cast<std::int32_t>(app_id), 0});
}

/// Why opening may have failed, for the error message.
std::string open_hint(const fs::path& path, Store::Mode mode) {
  std::error_code ec;
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec)) return " (directory '" + dir.string() + "' does not exist)";
  if (fs::is_directory(path, ec)) return " (it is a directory)";
  if (mode == Store::Mode::kReadOnly && !fs::exists(path, ec)) return " (the file does not exist)";
  return mode == Store::Mode::kReadOnly ? " (is the file readable?)"
                                        : " (are the directory and the file writable?)";
}

DbPtr open_handle(const fs::path& path, Store::Mode mode, std::chrono::milliseconds busy) {
  const int flags = mode == Store::Mode::kReadOnly ? SQLITE_OPEN_READONLY
                                                   : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
  sqlite3* raw = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &raw, flags, nullptr);
  DbPtr db(raw);
  if (rc != SQLITE_OK) fail_sqlite(path, db.get(), "opening the database" + open_hint(path, mode), rc);
  sqlite3_extended_result_codes(db.get(), 1);
  sqlite3_busy_timeout(db.get(), static_cast<int>(std::min<std::int64_t>(
                                     busy.count(), std::numeric_limits<int>::max())));
  if (mode != Store::Mode::kReadOnly && sqlite3_db_readonly(db.get(), "main") == 1)
    fail(path, "opening the database read-write: the file is not writable");
  return db;
}

std::string read_schema_version(const Connection& conn) {
  Statement st(conn, "SELECT value FROM meta WHERE key = 'schema_version'",
               "reading meta.schema_version");
  if (!st.step()) fail(conn.path(), "corrupt stickslip database: meta has no schema_version");
  return st.text(0);
}

/// One migration step from version `from` to from + 1 in one write transaction. Re-checks the
/// version inside the transaction, so two processes opening the same old file at once migrate
/// it once. Every existing table and row is kept as it is.
///  1 -> 2: adds the diagnoses table.
///  2 -> 3: adds the run counters of each study (filled from its runs), their triggers, and
///          v_study_progress reading them.
void migrate_step(const Connection& conn, int from) {
  const std::string step = "from version " + std::to_string(from) + " to " + std::to_string(from + 1);
  Transaction tx(conn, Transaction::Kind::kWrite, "migrating the schema " + step);
  if (read_schema_version(conn) == std::to_string(from)) {
    if (from == 1) conn.exec(kDiagnosesSql, "creating the diagnoses table (schema version 2)");
    else conn.exec(kRunCountersSql, "adding the run counters (schema version 3)");
    conn.exec(("UPDATE meta SET value = '" + std::to_string(from + 1) +
               "' WHERE key = 'schema_version'").c_str(),
              "writing meta.schema_version");
    Statement st(conn, "INSERT OR REPLACE INTO meta (key, value) VALUES ('migrated_at', ?1)",
                 "writing meta.migrated_at");
    st.bind_text(1, utc_now_iso8601()).run();
  }
  tx.commit("the schema migration " + step);
}

/// Accepts this build's version; a read-write open migrates an older database step by step
/// (see migrate_step), a read-only open reads it as it is (version 1: studies and runs only;
/// versions 1 and 2 count runs with their aggregate view).
void require_schema_version(const Connection& conn, Store::Mode mode) {
  std::string value = read_schema_version(conn);
  for (int from = 1; from < kStoreSchemaVersion; ++from) {
    if (value != std::to_string(from)) continue;
    if (mode == Store::Mode::kReadOnly) return;
    migrate_step(conn, from);
    value = read_schema_version(conn);
  }
  if (value != std::to_string(kStoreSchemaVersion))
    fail(conn.path(), "stickslip schema_version " + value + " is not supported by this build "
                          "(it reads version " + std::to_string(kStoreSchemaVersion) +
                          ", and migrates versions 1 to " +
                          std::to_string(kStoreSchemaVersion - 1) + ")");
}

void write_schema(const Connection& conn) {
  conn.exec(kSchemaSql, "creating the schema");
  conn.exec(kDiagnosesSql, "creating the diagnoses table");
  conn.exec(kRunCountersSql, "adding the run counters");
  conn.exec(("PRAGMA application_id = " + std::to_string(kStoreApplicationId)).c_str(),
            "setting the application_id");
  Statement ins(conn, "INSERT INTO meta (key, value) VALUES (?1, ?2)", "writing meta");
  const std::array<std::pair<const char*, std::string>, 3> rows{{
      {"schema_version", std::to_string(kStoreSchemaVersion)},
      {"application", "stickslip"},
      {"created_at", utc_now_iso8601()},
  }};
  for (const auto& [key, value] : rows) ins.reset().bind_text(1, key).bind_text(2, value).run();
}

/// Initialises an empty database. Re-checks inside the write transaction, so two processes
/// creating the same file at once end up with one schema.
void initialise(const Connection& conn) {
  Transaction tx(conn, Transaction::Kind::kWrite, "initialising the database");
  const DbIdentity id = read_identity(conn);
  if (id.empty()) write_schema(conn);
  else if (!id.ours()) fail_foreign(conn.path(), id);
  tx.commit("the new schema");
}

void configure(const Connection& conn, Store::Mode mode) {
  conn.exec("PRAGMA foreign_keys = ON", "enabling foreign keys");
  if (mode == Store::Mode::kReadOnly) return;
  Statement wal(conn, "PRAGMA journal_mode = WAL", "switching to WAL");
  if (!wal.step() || wal.text(0) != "wal")
    fail(conn.path(), "could not switch the database to WAL journal mode");
  conn.exec("PRAGMA synchronous = NORMAL", "setting synchronous = NORMAL");
}

/// Opens path and makes sure it is a stickslip database; nothing is written before the file
/// is known to be ours or empty.
Connection open_connection(const fs::path& path, Store::Mode mode,
                           std::chrono::milliseconds busy) {
  require_sqlite_header(path);
  Connection conn(path, open_handle(path, mode, busy));
  const DbIdentity id = read_identity(conn);
  if (id.empty()) {
    if (mode == Store::Mode::kReadOnly)
      fail(path, "not a stickslip database: the database is empty (open it read-write first)");
    initialise(conn);
  } else if (!id.ours()) {
    fail_foreign(path, id);
  }
  require_schema_version(conn, mode);
  configure(conn, mode);
  return conn;
}

// ---------------------------------------------------------------------------------------------
// Records
// ---------------------------------------------------------------------------------------------

constexpr std::array<double TracePoint::*, 6> kTraceColumns{
    &TracePoint::t, &TracePoint::F_d, &TracePoint::F_f,
    &TracePoint::x, &TracePoint::v,   &TracePoint::s};

/// One trace column as n little-endian IEEE-754 binary64 values (numpy dtype '<f8').
std::vector<unsigned char> encode_column(const std::vector<TracePoint>& trace,
                                         double TracePoint::*column) {
  std::vector<unsigned char> out(trace.size() * 8);
  for (std::size_t i = 0; i < trace.size(); ++i) {
    const auto bits = std::bit_cast<std::uint64_t>(trace[i].*column);
    for (std::size_t k = 0; k < 8; ++k) out[8 * i + k] = static_cast<unsigned char>(bits >> (8 * k));
  }
  return out;
}

void decode_column(const std::vector<unsigned char>& bytes, std::vector<TracePoint>& trace,
                   double TracePoint::*column) {
  for (std::size_t i = 0; i < trace.size(); ++i) {
    std::uint64_t bits = 0;
    for (std::size_t k = 0; k < 8; ++k) bits |= std::uint64_t{bytes[8 * i + k]} << (8 * k);
    trace[i].*column = std::bit_cast<double>(bits);
  }
}

constexpr const char* kStudyColumns =
    "id, name, spec_json, spec_hash, state, total_runs, created_at, started_at, finished_at, "
    "error, idempotency_key, request_hash";

std::string select_studies(const char* where_order) {
  return std::string("SELECT ") + kStudyColumns + " FROM studies " + where_order;
}

StudyRecord read_study(const Statement& st, const fs::path& path) {
  StudyRecord r;
  r.id = st.text(0);
  r.name = st.text(1);
  r.spec_json = st.text(2);
  r.spec_hash = st.text(3);
  const auto state = parse_study_state(st.text(4));
  if (!state) fail(path, "study " + r.id + " has an unknown state '" + st.text(4) + "'");
  r.state = *state;
  r.total_runs = st.int64(5);
  r.created_at = st.text(6);
  r.started_at = st.opt_text(7);
  r.finished_at = st.opt_text(8);
  r.error = st.opt_text(9);
  r.idempotency_key = st.opt_text(10);
  r.request_hash = st.opt_text(11);
  return r;
}

constexpr const char* kRunColumns =
    "study_id, design_index, param_hash, params_json, model, va_over_vd, status, error, "
    "wall_time_s, t_end, steps, rmse, finished_at";

RunRecord read_run(const Statement& st) {
  RunRecord r;
  r.study_id = st.text(0);
  r.design_index = st.int64(1);
  r.param_hash = st.text(2);
  r.params_json = st.text(3);
  r.model = st.opt_text(4);
  r.va_over_vd = st.opt_real(5);
  r.status = st.text(6);
  r.error = st.opt_text(7).value_or("");
  r.wall_time_s = st.real(8);
  r.t_end = st.real(9);
  r.steps = st.int64(10);
  r.rmse = st.opt_real(11);
  r.finished_at = st.text(12);
  return r;
}

/// Columns after (study_id, design_index) in stage_metrics, in this order.
constexpr const char* kStageColumns =
    "stage, t_start, t_end, amplitude, amplitude_raw, mean_force, mean_friction, slip_events, "
    "mean_period, rmse";

/// Reads kStageColumns starting at column c0.
StageMetricsRecord read_stage(const Statement& st, int c0) {
  StageMetricsRecord m;
  m.stage = static_cast<int>(st.int64(c0));
  m.t_start = st.real(c0 + 1);
  m.t_end = st.real(c0 + 2);
  m.amplitude = st.real(c0 + 3);
  m.amplitude_raw = st.real(c0 + 4);
  m.mean_force = st.real(c0 + 5);
  m.mean_friction = st.real(c0 + 6);
  m.slip_events = st.int64(c0 + 7);
  m.mean_period = st.real(c0 + 8);
  m.rmse = st.opt_real(c0 + 9);
  return m;
}

std::int64_t to_limit(std::size_t n) {
  return static_cast<std::int64_t>(
      std::min<std::uint64_t>(n, std::numeric_limits<std::int64_t>::max()));
}

bool is_json_object(const std::string& text) {
  const auto j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  return j.is_object();
}

bool is_json(const std::string& text) {
  return !nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false).is_discarded();
}

std::string run_label(const RunRecord& r) {
  return "run (" + r.study_id + ", " + std::to_string(r.design_index) + ")";
}

/// Checks a run before it is buffered; fills in stage numbers and finished_at.
void prepare_run(RunRecord& r, const fs::path& path) {
  const auto bad = [&](const std::string& why) { fail(path, "rejected " + run_label(r) + ": " + why); };
  if (r.study_id.empty()) bad("empty study_id");
  if (r.design_index < 0) bad("negative design_index");
  if (r.param_hash.empty()) bad("empty param_hash");
  if (!is_valid_run_status(r.status))
    bad("status '" + r.status + "' is not one of ok, diverged, invalid");
  if (!is_json_object(r.params_json)) bad("params_json is not a JSON object");
  std::vector<int> numbers;
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    if (r.stages[i].stage == 0) r.stages[i].stage = static_cast<int>(i + 1);
    if (r.stages[i].stage < 1) bad("stage numbers start at 1");
    numbers.push_back(r.stages[i].stage);
  }
  std::sort(numbers.begin(), numbers.end());
  if (std::adjacent_find(numbers.begin(), numbers.end()) != numbers.end())
    bad("repeated stage number");
  if (r.finished_at.empty()) r.finished_at = utc_now_iso8601();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Free functions
// ---------------------------------------------------------------------------------------------

std::string param_hash(std::string_view canonical_json) {
  std::uint64_t h = 0xcbf29ce484222325ULL;  // FNV-1a 64-bit offset basis
  for (const char c : canonical_json) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;  // FNV-1a 64-bit prime
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, h);
  return buf;
}

namespace {
std::string new_id(const char* prefix) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  std::random_device rd;
  const std::uint32_t rnd = rd();
  char buf[32];
  const std::uint64_t ms48 = static_cast<std::uint64_t>(ms) & 0xffffffffffffULL;
  std::snprintf(buf, sizeof buf, "%s-%012" PRIx64 "%08" PRIx32, prefix, ms48, rnd);
  return buf;
}
}  // namespace

std::string new_study_id() { return new_id("st"); }
std::string new_diagnosis_id() { return new_id("dg"); }

std::string utc_now_iso8601() {
  const auto now = std::chrono::system_clock::now();
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch());
  const std::time_t secs = static_cast<std::time_t>(ms.count() / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S", &tm);
  char buf[48];
  std::snprintf(buf, sizeof buf, "%s.%03dZ", date, static_cast<int>(ms.count() % 1000));
  return buf;
}

const char* to_string(StudyState s) noexcept {
  switch (s) {
    case StudyState::kQueued: return "queued";
    case StudyState::kRunning: return "running";
    case StudyState::kSucceeded: return "succeeded";
    case StudyState::kFailed: return "failed";
    case StudyState::kCancelled: return "cancelled";
  }
  return "unknown";
}

std::optional<StudyState> parse_study_state(std::string_view s) noexcept {
  for (const StudyState st : {StudyState::kQueued, StudyState::kRunning, StudyState::kSucceeded,
                              StudyState::kFailed, StudyState::kCancelled})
    if (s == to_string(st)) return st;
  return std::nullopt;
}

bool is_valid_run_status(std::string_view status) noexcept {
  return status == "ok" || status == "diverged" || status == "invalid";
}

// ---------------------------------------------------------------------------------------------
// Store
// ---------------------------------------------------------------------------------------------

struct Store::Impl {
  Connection conn;

  std::optional<StudyRecord> study_where(const char* where, const std::string& value,
                                         const std::string* value2 = nullptr) {
    Statement st(conn, select_studies(where).c_str(), "reading a study");
    st.bind_text(1, value);
    if (value2 != nullptr) st.bind_text(2, *value2);
    if (!st.step()) return std::nullopt;
    return read_study(st, conn.path());
  }

  void insert_study(const NewStudy& s, const std::string& id) {
    Statement st(conn,
                 "INSERT INTO studies (id, name, spec_json, spec_hash, state, total_runs, "
                 "created_at, idempotency_key, request_hash) "
                 "VALUES (?1, ?2, ?3, ?4, 'queued', ?5, ?6, ?7, ?8)",
                 "inserting study " + id);
    st.bind_text(1, id).bind_text(2, s.name).bind_text(3, s.spec_json).bind_text(4, s.spec_hash);
    st.bind_int(5, s.total_runs).bind_text(6, utc_now_iso8601());
    st.bind_opt_text(7, s.idempotency_key).bind_opt_text(8, s.request_hash);
    st.run();
  }

  /// Stage metrics of runs lo..hi (inclusive), merged into runs (sorted by design_index).
  void attach_stages(const std::string& study_id, std::vector<RunRecord>& runs) {
    Statement st(conn,
                 (std::string("SELECT design_index, ") + kStageColumns +
                  " FROM stage_metrics WHERE study_id = ?1 AND design_index BETWEEN ?2 AND ?3 "
                  "ORDER BY design_index, stage")
                     .c_str(),
                 "reading stage metrics of study " + study_id);
    st.bind_text(1, study_id).bind_int(2, runs.front().design_index);
    st.bind_int(3, runs.back().design_index);
    auto it = runs.begin();
    while (st.step()) {
      const std::int64_t index = st.int64(0);
      while (it != runs.end() && it->design_index < index) ++it;
      if (it == runs.end()) break;
      if (it->design_index == index) it->stages.push_back(read_stage(st, 1));
    }
  }
};

Store::Store(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
Store::Store(Store&&) noexcept = default;
Store& Store::operator=(Store&&) noexcept = default;
Store::~Store() = default;

Store Store::open(const std::filesystem::path& path, Mode mode,
                  std::chrono::milliseconds busy_timeout) {
  return Store(std::make_unique<Impl>(Impl{open_connection(path, mode, busy_timeout)}));
}

const std::filesystem::path& Store::path() const noexcept { return impl_->conn.path(); }

CreatedStudy Store::create_study(const NewStudy& s) {
  const std::string id = s.id.empty() ? new_study_id() : s.id;
  if (!is_json(s.spec_json)) fail(path(), "creating study " + id + ": spec_json is not JSON");
  if (s.total_runs < 0) fail(path(), "creating study " + id + ": negative total_runs");
  Transaction tx(impl_->conn, Transaction::Kind::kWrite, "creating study " + id);
  if (s.idempotency_key) {
    if (auto existing = impl_->study_where("WHERE idempotency_key = ?1", *s.idempotency_key)) {
      tx.commit("idempotency lookup");
      return {std::move(*existing), false};
    }
  }
  if (impl_->study_where("WHERE id = ?1", id))
    fail(path(), "creating study " + id + ": a study with this id already exists");
  impl_->insert_study(s, id);
  auto stored = impl_->study_where("WHERE id = ?1", id);
  tx.commit("study " + id);
  return {std::move(stored.value()), true};
}

std::optional<StudyRecord> Store::get_study(const std::string& id) {
  return impl_->study_where("WHERE id = ?1", id);
}

std::optional<StudyRecord> Store::find_by_idempotency_key(const std::string& key) {
  return impl_->study_where("WHERE idempotency_key = ?1", key);
}

std::optional<StudyRecord> Store::find_newest_by_name(const std::string& name) {
  return impl_->study_where("WHERE name = ?1 ORDER BY id DESC LIMIT 1", name);
}

std::optional<StudyRecord> Store::find_resumable(const std::string& name,
                                                const std::string& spec_hash) {
  return impl_->study_where(
      "WHERE name = ?1 AND spec_hash = ?2 AND state <> 'cancelled' ORDER BY id DESC LIMIT 1", name,
      &spec_hash);
}

std::vector<StudyRecord> Store::list_studies(std::size_t page_size, const std::string& after_id) {
  Statement st(impl_->conn, select_studies("WHERE id > ?1 ORDER BY id LIMIT ?2").c_str(),
               "listing studies");
  st.bind_text(1, after_id).bind_int(2, to_limit(page_size));
  std::vector<StudyRecord> out;
  while (st.step()) out.push_back(read_study(st, path()));
  return out;
}

namespace {
// One state-transition rule for both kinds of job (studies, diagnoses): started_at is set on
// the first 'running', finished_at on a terminal state and cleared otherwise. table is one of
// the two fixed table names; kind names the job in errors.
void set_job_state(const Connection& conn, const char* table, const char* kind,
                   const std::string& id, StudyState state,
                   const std::optional<std::string>& error) {
  const std::string sql =
      std::string("UPDATE ") + table +
      " SET state = ?1, error = ?2, "
      "started_at = CASE WHEN ?1 = 'running' THEN COALESCE(started_at, ?3) "
      "                  ELSE started_at END, "
      "finished_at = CASE WHEN ?1 IN ('succeeded', 'failed', 'cancelled') THEN ?3 "
      "                   ELSE NULL END "
      "WHERE id = ?4";
  const std::string doing = std::string("setting the state of ") + kind + " " + id;
  Statement st(conn, sql.c_str(), doing);
  st.bind_text(1, to_string(state)).bind_opt_text(2, error).bind_text(3, utc_now_iso8601());
  st.bind_text(4, id).run();
  if (conn.changes() == 0) fail(conn.path(), doing + ": no such " + kind);
}
}  // namespace

void Store::set_study_state(const std::string& id, StudyState state,
                            const std::optional<std::string>& error) {
  set_job_state(impl_->conn, "studies", "study", id, state, error);
}

std::vector<std::int64_t> Store::completed_design_indices(const std::string& study_id) {
  Statement st(impl_->conn,
               "SELECT design_index FROM runs WHERE study_id = ?1 ORDER BY design_index",
               "reading completed design indices of study " + study_id);
  st.bind_text(1, study_id);
  std::vector<std::int64_t> out;
  while (st.step()) out.push_back(st.int64(0));
  return out;
}

std::vector<RunRecord> Store::get_runs(const std::string& study_id, std::int64_t after_index,
                                       std::size_t limit) {
  const std::string doing = "reading runs of study " + study_id;
  Transaction snapshot(impl_->conn, Transaction::Kind::kRead, doing);
  Statement st(impl_->conn,
               (std::string("SELECT ") + kRunColumns +
                " FROM runs WHERE study_id = ?1 AND design_index > ?2 "
                "ORDER BY design_index LIMIT ?3")
                   .c_str(),
               doing);
  st.bind_text(1, study_id).bind_int(2, after_index).bind_int(3, to_limit(limit));
  std::vector<RunRecord> runs;
  while (st.step()) runs.push_back(read_run(st));
  if (!runs.empty()) impl_->attach_stages(study_id, runs);
  snapshot.commit(doing);
  return runs;
}

RunCounts Store::count_runs(const std::string& study_id) {
  Statement st(impl_->conn,
               "SELECT total, done, ok, failed FROM v_study_progress WHERE study_id = ?1",
               "counting runs of study " + study_id);
  st.bind_text(1, study_id);
  if (!st.step()) fail(path(), "counting runs of study " + study_id + ": no such study");
  return {st.int64(0), st.int64(1), st.int64(2), st.int64(3)};
}

std::optional<std::vector<TracePoint>> Store::get_trace(const std::string& study_id,
                                                        std::int64_t design_index) {
  Statement st(impl_->conn,
               "SELECT n_samples, t, F_d, F_f, x, v, s FROM traces "
               "WHERE study_id = ?1 AND design_index = ?2",
               "reading a trace of study " + study_id);
  st.bind_text(1, study_id).bind_int(2, design_index);
  if (!st.step()) return std::nullopt;
  std::vector<TracePoint> trace(static_cast<std::size_t>(st.int64(0)));
  for (std::size_t c = 0; c < kTraceColumns.size(); ++c) {
    const auto bytes = st.blob(static_cast<int>(c) + 1);
    if (bytes.size() != 8 * trace.size())
      fail(path(), "corrupt trace of study " + study_id + " design_index " +
                       std::to_string(design_index) + ": column length mismatch");
    decode_column(bytes, trace, kTraceColumns[c]);
  }
  return trace;
}

// --- diagnoses ---

namespace {

constexpr const char* kDiagnosisColumns =
    "id, name, request_hash, state, created_at, started_at, finished_at, error, idempotency_key";

DiagnosisRecord read_diagnosis(const Statement& st, const fs::path& path) {
  DiagnosisRecord r;
  r.id = st.text(0);
  r.name = st.text(1);
  r.request_hash = st.text(2);
  const auto state = parse_study_state(st.text(3));
  if (!state) fail(path, "diagnosis " + r.id + " has an unknown state '" + st.text(3) + "'");
  r.state = *state;
  r.created_at = st.text(4);
  r.started_at = st.opt_text(5);
  r.finished_at = st.opt_text(6);
  r.error = st.opt_text(7);
  r.idempotency_key = st.opt_text(8);
  return r;
}

std::optional<DiagnosisRecord> diagnosis_where(const Connection& conn, const char* where,
                                               const std::string& value, bool with_result) {
  const std::string sql = std::string("SELECT ") + kDiagnosisColumns +
                          (with_result ? ", result_json" : "") + " FROM diagnoses " + where;
  Statement st(conn, sql.c_str(), "reading a diagnosis");
  st.bind_text(1, value);
  if (!st.step()) return std::nullopt;
  DiagnosisRecord r = read_diagnosis(st, conn.path());
  if (with_result) r.result_json = st.opt_text(9);
  return r;
}

}  // namespace

CreatedDiagnosis Store::create_diagnosis(const NewDiagnosis& d) {
  const std::string id = d.id.empty() ? new_diagnosis_id() : d.id;
  if (!is_json_object(d.request_json))
    fail(path(), "creating diagnosis " + id + ": request_json is not a JSON object");
  const auto& conn = impl_->conn;
  Transaction tx(conn, Transaction::Kind::kWrite, "creating diagnosis " + id);
  if (d.idempotency_key) {
    if (auto existing = diagnosis_where(conn, "WHERE idempotency_key = ?1", *d.idempotency_key,
                                        true)) {
      tx.commit("idempotency lookup");
      return {std::move(*existing), false};
    }
  }
  if (diagnosis_where(conn, "WHERE id = ?1", id, false))
    fail(path(), "creating diagnosis " + id + ": a diagnosis with this id already exists");
  Statement st(conn,
               "INSERT INTO diagnoses (id, name, request_json, request_hash, state, created_at, "
               "idempotency_key) VALUES (?1, ?2, ?3, ?4, 'queued', ?5, ?6)",
               "inserting diagnosis " + id);
  st.bind_text(1, id).bind_text(2, d.name).bind_text(3, d.request_json);
  st.bind_text(4, d.request_hash).bind_text(5, utc_now_iso8601());
  st.bind_opt_text(6, d.idempotency_key).run();
  auto stored = diagnosis_where(conn, "WHERE id = ?1", id, true);
  tx.commit("diagnosis " + id);
  return {std::move(stored.value()), true};
}

std::optional<DiagnosisRecord> Store::get_diagnosis(const std::string& id) {
  return diagnosis_where(impl_->conn, "WHERE id = ?1", id, true);
}

std::optional<std::string> Store::get_diagnosis_request(const std::string& id) {
  Statement st(impl_->conn, "SELECT request_json FROM diagnoses WHERE id = ?1",
               "reading the request of diagnosis " + id);
  st.bind_text(1, id);
  if (!st.step()) return std::nullopt;
  return st.text(0);
}

std::optional<DiagnosisRecord> Store::find_diagnosis_by_idempotency_key(const std::string& key) {
  return diagnosis_where(impl_->conn, "WHERE idempotency_key = ?1", key, true);
}

std::vector<DiagnosisRecord> Store::list_diagnoses(std::size_t page_size,
                                                   const std::string& after_id) {
  const std::string sql = std::string("SELECT ") + kDiagnosisColumns +
                          " FROM diagnoses WHERE id > ?1 ORDER BY id LIMIT ?2";
  Statement st(impl_->conn, sql.c_str(), "listing diagnoses");
  st.bind_text(1, after_id).bind_int(2, to_limit(page_size));
  std::vector<DiagnosisRecord> out;
  while (st.step()) out.push_back(read_diagnosis(st, path()));
  return out;
}

void Store::set_diagnosis_state(const std::string& id, StudyState state,
                                const std::optional<std::string>& error) {
  set_job_state(impl_->conn, "diagnoses", "diagnosis", id, state, error);
}

bool Store::requeue_diagnosis(const std::string& id) {
  Statement st(impl_->conn,
               "UPDATE diagnoses SET state = 'queued' WHERE id = ?1 AND state = 'running'",
               "re-queueing diagnosis " + id);
  st.bind_text(1, id).run();
  return impl_->conn.changes() > 0;
}

bool Store::finish_diagnosis(const std::string& id, StudyState state,
                             const std::optional<std::string>& result_json,
                             const std::optional<std::string>& error) {
  if (state != StudyState::kSucceeded && state != StudyState::kFailed)
    fail(path(), "finishing diagnosis " + id + ": the state must be succeeded or failed");
  if (result_json && !is_json_object(*result_json))
    fail(path(), "finishing diagnosis " + id + ": result_json is not a JSON object");
  Statement st(impl_->conn,
               "UPDATE diagnoses SET state = ?1, result_json = ?2, error = ?3, finished_at = ?4 "
               "WHERE id = ?5 AND state IN ('queued', 'running')",
               "finishing diagnosis " + id);
  st.bind_text(1, to_string(state)).bind_opt_text(2, result_json).bind_opt_text(3, error);
  st.bind_text(4, utc_now_iso8601()).bind_text(5, id).run();
  return impl_->conn.changes() > 0;
}


// ---------------------------------------------------------------------------------------------
// RunWriter
// ---------------------------------------------------------------------------------------------

struct RunWriter::Impl {
  using Clock = std::chrono::steady_clock;
  enum class Outcome { kInserted, kDuplicate, kMismatch };

  Impl(Connection c, WriterOptions o)
      : conn(std::move(c)),
        options(o),
        insert_run(conn,
                   "INSERT INTO runs (study_id, design_index, param_hash, params_json, model, "
                   "va_over_vd, status, error, wall_time_s, t_end, steps, rmse, finished_at) "
                   "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13) "
                   "ON CONFLICT (study_id, design_index) DO NOTHING",
                   "inserting a run", true),
        stored_hash(conn,
                    "SELECT param_hash FROM runs WHERE study_id = ?1 AND design_index = ?2",
                    "reading the param_hash of a stored run", true),
        insert_stage(conn,
                     (std::string("INSERT INTO stage_metrics (study_id, design_index, ") +
                      kStageColumns + ") VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)")
                         .c_str(),
                     "inserting stage metrics", true),
        insert_trace(conn,
                     "INSERT INTO traces (study_id, design_index, n_samples, t, F_d, F_f, x, v, s) "
                     "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
                     "inserting a trace", true) {}

  // Member order matters: statements are finalised before the connection closes.
  Connection conn;
  WriterOptions options;
  Statement insert_run, stored_hash, insert_stage, insert_trace;
  std::vector<RunRecord> buffer;
  Clock::time_point last_commit = Clock::now();

  bool due() const {
    if (buffer.empty()) return false;
    return buffer.size() >= options.max_batch || Clock::now() - last_commit >= options.max_delay;
  }

  void write_stages(const RunRecord& r) {
    for (const auto& m : r.stages) {
      insert_stage.reset().bind_text(1, r.study_id).bind_int(2, r.design_index);
      insert_stage.bind_int(3, m.stage).bind_real(4, m.t_start).bind_real(5, m.t_end);
      insert_stage.bind_real(6, m.amplitude).bind_real(7, m.amplitude_raw);
      insert_stage.bind_real(8, m.mean_force).bind_real(9, m.mean_friction);
      insert_stage.bind_int(10, m.slip_events).bind_real(11, m.mean_period);
      insert_stage.bind_real(12, m.rmse).run();
    }
  }

  void write_trace(const RunRecord& r) {
    if (r.trace.empty()) return;
    insert_trace.reset().bind_text(1, r.study_id).bind_int(2, r.design_index);
    insert_trace.bind_int(3, static_cast<std::int64_t>(r.trace.size()));
    for (std::size_t c = 0; c < kTraceColumns.size(); ++c)
      insert_trace.bind_blob(static_cast<int>(c) + 4, encode_column(r.trace, kTraceColumns[c]));
    insert_trace.run();
  }

  Outcome existing_outcome(const RunRecord& r) {
    stored_hash.reset().bind_text(1, r.study_id).bind_int(2, r.design_index);
    const bool found = stored_hash.step();
    const std::string hash = found ? stored_hash.text(0) : std::string();
    stored_hash.reset();
    return found && hash == r.param_hash ? Outcome::kDuplicate : Outcome::kMismatch;
  }

  Outcome write_run(const RunRecord& r) {
    insert_run.reset().bind_text(1, r.study_id).bind_int(2, r.design_index);
    insert_run.bind_text(3, r.param_hash).bind_text(4, r.params_json).bind_opt_text(5, r.model);
    insert_run.bind_real(6, r.va_over_vd).bind_text(7, r.status);
    if (r.error.empty()) insert_run.bind_null(8);
    else insert_run.bind_text(8, r.error);
    insert_run.bind_real(9, r.wall_time_s).bind_real(10, r.t_end).bind_int(11, r.steps);
    insert_run.bind_real(12, r.rmse).bind_text(13, r.finished_at).run();
    if (conn.changes() == 0) return existing_outcome(r);
    write_stages(r);
    write_trace(r);
    return Outcome::kInserted;
  }

  /// Writes one run inside its own savepoint: a constraint violation drops just this run (its
  /// reason is appended to rejected); any other error propagates.
  void write_run_atomically(const RunRecord& r, FlushResult& result,
                            std::vector<std::string>& rejected) {
    conn.exec("SAVEPOINT run", "opening a savepoint for " + run_label(r));
    try {
      const Outcome o = write_run(r);
      if (o == Outcome::kInserted) ++result.inserted;
      if (o == Outcome::kDuplicate) ++result.duplicates;
      if (o == Outcome::kMismatch)
        rejected.push_back(run_label(r) + " is already stored with a different param_hash "
                           "(new " + r.param_hash + ")");
    } catch (const SqliteError& e) {
      if (!e.is_constraint()) throw;
      conn.exec("ROLLBACK TO run", "rolling back " + run_label(r));
      rejected.push_back(run_label(r) + ": " + e.what());
    }
    conn.exec("RELEASE run", "releasing the savepoint of " + run_label(r));
  }

  FlushResult flush() {
    if (buffer.empty()) return {};
    const std::string doing = "a batch of " + std::to_string(buffer.size()) + " runs";
    FlushResult result;
    std::vector<std::string> rejected;
    {
      Transaction tx(conn, Transaction::Kind::kWrite, doing);
      for (const auto& r : buffer) write_run_atomically(r, result, rejected);
      tx.commit(doing);
    }
    buffer.clear();
    last_commit = Clock::now();
    if (!rejected.empty()) throw_rejected(rejected, result);
    return result;
  }

  [[noreturn]] void throw_rejected(const std::vector<std::string>& rejected,
                                   const FlushResult& result) const {
    std::string msg = "committed " + std::to_string(result.inserted) + " runs (" +
                      std::to_string(result.duplicates) + " duplicates) but left out " +
                      std::to_string(rejected.size()) + ":";
    for (const auto& r : rejected) msg += "\n  " + r;
    fail(conn.path(), msg);
  }
};

RunWriter::RunWriter(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
RunWriter::RunWriter(RunWriter&&) noexcept = default;

RunWriter& RunWriter::operator=(RunWriter&& other) noexcept {
  if (this != &other) {
    RunWriter old(std::move(*this));  // flushes on destruction
    impl_ = std::move(other.impl_);
  }
  return *this;
}

RunWriter::~RunWriter() {
  if (!impl_ || impl_->buffer.empty()) return;
  try {
    impl_->flush();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stickslip RunWriter: final flush failed: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "stickslip RunWriter: final flush failed\n");
  }
}

RunWriter RunWriter::open(const std::filesystem::path& path, WriterOptions options) {
  if (options.max_batch == 0) options.max_batch = 1;
  Connection conn = open_connection(path, Store::Mode::kReadWriteCreate, options.busy_timeout);
  return RunWriter(std::make_unique<Impl>(std::move(conn), options));
}

void RunWriter::add(RunRecord run) {
  prepare_run(run, impl_->conn.path());
  impl_->buffer.push_back(std::move(run));
  flush_if_due();
}

bool RunWriter::flush_if_due() {
  if (!impl_->due()) return false;
  impl_->flush();
  return true;
}

FlushResult RunWriter::flush() { return impl_->flush(); }

std::size_t RunWriter::buffered() const noexcept { return impl_->buffer.size(); }

const std::filesystem::path& RunWriter::path() const noexcept { return impl_->conn.path(); }

}  // namespace stickslip::store
