// Opening a stickslip database: the errors, checking a file's header before SQLite touches it,
// opening the handle and configuring the connection (connection.h).
#include "connection.h"

#include <algorithm>
#include <array>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <vector>

namespace stickslip::store::detail {

std::string where(const fs::path& path) { return "stickslip store '" + path.string() + "'"; }

[[noreturn]] void fail(const fs::path& path, std::string_view what) {
  throw StoreError(where(path) + ": " + std::string(what));
}

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

std::int64_t query_int(const Connection& conn, const char* sql, const std::string& doing) {
  Statement st(conn, sql, doing);
  if (!st.step()) fail(conn.path(), "no result when " + std::string(doing));
  return st.int64(0);
}

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

namespace {

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

void configure(const Connection& conn, Store::Mode mode) {
  conn.exec("PRAGMA foreign_keys = ON", "enabling foreign keys");
  if (mode == Store::Mode::kReadOnly) return;
  Statement wal(conn, "PRAGMA journal_mode = WAL", "switching to WAL");
  if (!wal.step() || wal.text(0) != "wal")
    fail(conn.path(), "could not switch the database to WAL journal mode");
  conn.exec("PRAGMA synchronous = NORMAL", "setting synchronous = NORMAL");
}

/// Rows of a PRAGMA that checks the file, stopped after budget (then *finished is false). A
/// statement that fails because a page is damaged (SQLITE_CORRUPT, SQLITE_NOTADB) is a problem.
std::vector<std::string> check_rows(const Connection& conn, const char* pragma,
                                    std::chrono::milliseconds budget, bool* finished) {
  using Clock = std::chrono::steady_clock;
  Clock::time_point d = budget.count() > 0 ? Clock::now() + budget : Clock::time_point::max();
  sqlite3_progress_handler(
      conn.get(), 10000,
      [](void* p) { return Clock::now() > *static_cast<Clock::time_point*>(p) ? 1 : 0; }, &d);
  std::vector<std::string> rows;
  *finished = true;
  try {
    const std::string sql = std::string("PRAGMA ") + pragma;
    Statement st(conn, sql.c_str(), "checking the file (" + sql + ")");
    while (st.step()) rows.push_back(st.text(0));
  } catch (const SqliteError& e) {
    const int primary = e.code() & 0xff;
    if (primary == SQLITE_INTERRUPT) *finished = false;
    else if (primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB) rows.push_back(e.what());
    else {
      sqlite3_progress_handler(conn.get(), 0, nullptr, nullptr);
      throw;
    }
  }
  sqlite3_progress_handler(conn.get(), 0, nullptr, nullptr);
  if (rows.size() == 1 && rows[0] == "ok") rows.clear();
  return rows;
}

std::string first_lines(const std::vector<std::string>& rows, std::size_t n) {
  std::string out;
  for (std::size_t i = 0; i < rows.size() && i < n; ++i) out += (i ? "; " : "") + rows[i];
  if (rows.size() > n) out += "; ...";
  return out;
}

/// The start-up check of a writer (docs/store.md, Damage): PRAGMA quick_check within
/// kQuickCheckBudget; a damaged file is refused before anything is written to it.
void require_quick_check(const Connection& conn) {
  bool finished = true;
  const auto rows = check_rows(conn, "quick_check(20)", kQuickCheckBudget, &finished);
  if (!rows.empty())
    fail(conn.path(), "the file is damaged (PRAGMA quick_check: " + first_lines(rows, 5) +
                          "); nothing was written to it. Run `stickslip store check " +
                          conn.path().string() +
                          "` for the full check and restore the file from a backup (or "
                          "`sqlite3 DB .recover`)");
}

}  // namespace

StoreCheck check_store_file(const fs::path& path) {
  require_sqlite_header(path);
  Connection conn(path, open_handle(path, Store::Mode::kReadOnly, Store::kDefaultBusyTimeout));
  const DbIdentity id = read_identity(conn);
  if (id.empty()) fail(path, "not a stickslip database: the database is empty");
  if (!id.ours()) fail_foreign(path, id);
  StoreCheck out;
  bool finished = true;
  out.problems = check_rows(conn, "integrity_check(100)", std::chrono::milliseconds(0), &finished);
  try {
    Statement fk(conn, "PRAGMA foreign_key_check", "checking foreign keys");
    while (fk.step()) ++out.foreign_key_violations;
  } catch (const SqliteError& e) {
    out.problems.push_back(e.what());  // a damaged page on the way
  }
  return out;
}

Connection open_connection(const fs::path& path, Store::Mode mode,
                           std::chrono::milliseconds busy) {
  require_sqlite_header(path);
  Connection conn(path, open_handle(path, mode, busy));
  const DbIdentity id = read_identity(conn);
  if (!id.empty() && !id.ours()) fail_foreign(path, id);
  if (mode != Store::Mode::kReadOnly) {
    // One writer per store: take (or join) this process's writer lock before anything is
    // written, and check a file this process has not checked yet.
    conn.hold(WriterLock::acquire(path));
    if (!conn.lock()->checked()) {
      if (!id.empty()) require_quick_check(conn);
      conn.lock()->mark_checked();
    }
  }
  if (id.empty()) {
    if (mode == Store::Mode::kReadOnly)
      fail(path, "not a stickslip database: the database is empty (open it read-write first)");
    initialise(conn);
  }
  require_schema_version(conn, mode);
  configure(conn, mode);
  return conn;
}

}  // namespace stickslip::store::detail
