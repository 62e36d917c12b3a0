#pragma once
// The single-writer lock of a store (docs/store.md, "One writer").
//
// A store has one writing process at a time. The writer holds flock(2) LOCK_EX on a separate
// file next to the database, `<db>.lock`, and writes a one-line JSON description of itself into
// it (pid, host, program, since, and a server's URL). flock, not fcntl: it belongs to the open
// file description, so it never interferes with SQLite's own POSIX locks on the database (closing
// any descriptor of a file drops all of a process's POSIX locks on it; see the comment on
// read_header_via_vfs), and the kernel releases it when the process exits or crashes: a lock
// is never stale, only the description left in the file may be.
//
// Every read-write Store::open and RunWriter::open takes the lock, or joins it when this
// process already holds it, and keeps it while it is open; a read-only open never touches it.
// A program that writes over a longer span than one connection (stickslipd, `stickslip study
// run`) holds a WriterLock itself for its whole life, so that nobody can slip in between two of
// its connections, and names itself in the description. Another process's read-write open then
// fails with StoreLockedError naming the holder.
//
// The first read-write open of a process after it took the lock runs a bounded
// `PRAGMA quick_check` before anything is written (store.h, Store::open).
//
// The lock is per process: every thread of the holder may open read-write connections. A child
// made by fork() shares its parent's lock (the open file description is inherited); an exec()ed
// one does not (O_CLOEXEC). Keep the database on a local file system (WAL needs it anyway).

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "stickslip/store/store.h"

namespace stickslip::store {

/// Who holds a store's writer lock, as written into `<db>.lock`.
struct LockHolder {
  long pid = 0;
  std::string host, program, since, url;  ///< since: ISO-8601 UTC; url: empty unless a server
  /// e.g. "stickslipd (pid 4242 on host lab1, since 2026-11-25T10:00:00.000Z, serving
  /// http://127.0.0.1:8080)"
  std::string describe() const;
};

/// Another process holds the writer lock.
class StoreLockedError : public StoreError {
 public:
  StoreLockedError(const std::string& message, std::optional<LockHolder> holder)
      : StoreError(message), holder_(std::move(holder)) {}
  /// nullopt when the holder's description could not be read.
  const std::optional<LockHolder>& holder() const noexcept { return holder_; }

 private:
  std::optional<LockHolder> holder_;
};

class WriterLock {
 public:
  /// Takes this process's writer lock on db, or joins it when the process holds it already.
  /// program names the holder in the description (empty: the executable's name; a later
  /// acquire with a name renames it). Throws StoreLockedError naming the holder when another
  /// process holds it, StoreError when `<db>.lock` cannot be created.
  static WriterLock acquire(const std::filesystem::path& db, const std::string& program = {});
  /// The holder of db's lock now, or nullopt when nobody holds it (reads `<db>.lock`).
  static std::optional<LockHolder> holder(const std::filesystem::path& db);
  /// `<db>.lock`.
  static std::filesystem::path lock_path(const std::filesystem::path& db);

  WriterLock(WriterLock&&) noexcept;
  WriterLock& operator=(WriterLock&&) noexcept;
  WriterLock(const WriterLock&) = delete;
  WriterLock& operator=(const WriterLock&) = delete;
  ~WriterLock();  ///< the process releases the lock when its last WriterLock of db goes

  /// Records the URL under which this process serves the store (a server, once it listens).
  void set_url(const std::string& url);
  /// Whether the start-up quick_check has run since this process took the lock; mark_checked
  /// records that it has (Store::open does both).
  bool checked() const;
  void mark_checked();

  struct File;

 private:
  explicit WriterLock(std::shared_ptr<File> file) noexcept;
  std::shared_ptr<File> file_;
};

}  // namespace stickslip::store
