#pragma once
// Internal to stickslip_store: the thin RAII layer over sqlite3 (Connection, Statement,
// Transaction) that every file of the store uses, the errors it throws, and what opening a
// database needs (connection.cpp opens and checks a file, schema.cpp creates and migrates the
// schema).
#include <sqlite3.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "stickslip/store/store.h"
#include "stickslip/store/writer_lock.h"

namespace stickslip::store::detail {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Errors (connection.cpp)
// ---------------------------------------------------------------------------------------------

/// "stickslip store '<path>'": how every error message starts.
std::string where(const fs::path& path);
/// Throws StoreError "<where>: <what>".
[[noreturn]] void fail(const fs::path& path, std::string_view what);

/// An SQLite error; keeps the extended result code so that the writer can tell a constraint
/// violation of one run from a failure of the whole transaction.
class SqliteError : public StoreError {
 public:
  SqliteError(const std::string& message, int code) : StoreError(message, code) {}
  int code() const noexcept { return sqlite_code(); }
  bool is_constraint() const noexcept { return (code() & 0xff) == SQLITE_CONSTRAINT; }
};

SqliteError sqlite_error(const fs::path& path, sqlite3* db, std::string_view doing, int rc);
[[noreturn]] void fail_sqlite(const fs::path& path, sqlite3* db, std::string_view doing, int rc);

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
  /// Keeps the process's writer lock while this read-write connection is open.
  void hold(WriterLock lock) { lock_.emplace(std::move(lock)); }
  WriterLock* lock() noexcept { return lock_ ? &*lock_ : nullptr; }

 private:
  fs::path path_;
  std::optional<WriterLock> lock_;  // declared before db_: released after the handle closes
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
  /// An empty v is a zero-length blob, not NULL (sqlite3_bind_blob64 of a null pointer is NULL).
  Statement& bind_blob(int i, const std::vector<unsigned char>& v) {
    if (v.empty()) return check(sqlite3_bind_zeroblob64(stmt_.get(), i, 0));
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

/// The integer in the first column of the first row of sql.
std::int64_t query_int(const Connection& conn, const char* sql, const std::string& doing);

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
// Opening a database (connection.cpp) and its schema (schema.cpp)
// ---------------------------------------------------------------------------------------------

struct DbIdentity {
  std::int64_t application_id = 0;
  std::int64_t schema_objects = 0;
  bool empty() const noexcept { return application_id == 0 && schema_objects == 0; }
  bool ours() const noexcept { return application_id == kStoreApplicationId; }
};

DbIdentity read_identity(const Connection& conn);
[[noreturn]] void fail_foreign(const fs::path& path, const DbIdentity& id);

/// Opens path and makes sure it is a stickslip database; nothing is written before the file
/// is known to be ours or empty.
Connection open_connection(const fs::path& path, Store::Mode mode,
                           std::chrono::milliseconds busy);

/// A read-only connection reading an older schema version as it is: TEMP views give it the
/// version-4 jobs table (schema.cpp).
void add_jobs_view(const Connection& conn, int version);

/// The full check of a file on a read-only connection (store.h, check_store).
StoreCheck check_store_file(const fs::path& path);

/// Creates the schema in an empty database (schema.cpp).
void initialise(const Connection& conn);
/// Accepts this build's schema version; a read-write open migrates an older one (schema.cpp).
void require_schema_version(const Connection& conn, Store::Mode mode);

}  // namespace stickslip::store::detail
