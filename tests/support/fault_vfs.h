#pragma once
// Test support: an SQLite VFS shim that makes file operations fail on demand, in the spirit of
// SQLite's own I/O-error tests (test_vfs.c, the "ioerr" and "fault" suites).
//
// While a FaultVfs exists it is the process's default VFS, so every connection opened meanwhile
// goes through it (the store opens every connection, and reads a file's header, through the
// default VFS: no option of the store is needed). Everything is forwarded to the VFS that was the
// default before, except that
//  - arm(kind, n) makes the n-th call of that kind from now fail (once, or with persist every
//    call from the n-th on, like a disk that filled up or went read-only);
//  - fail_writes(code) makes every write, truncate and sync fail with code until fail_writes(0).
// Kinds (each counted over every file the process opens through the shim):
//  - kWrite: xWrite and xTruncate (database, WAL, journal), default code SQLITE_IOERR_WRITE;
//  - kSync:  xSync, default code SQLITE_IOERR_FSYNC;
//  - kLock:  xLock on the database file and xShmLock on the WAL index (every lock SQLite takes),
//            default code SQLITE_IOERR_LOCK (xShmLock: SQLITE_IOERR_SHMLOCK); SQLITE_BUSY is the
//            code of a lock held by someone else.
// Reads never fail. Unlocks never fail (SQLite cannot report them).
//
// Also built as a preloadable library (tests/faults/fault_vfs_preload.cpp) that puts the same
// shim into a real stickslipd or stickslip process, configured by the environment.
#include <sqlite3.h>

#include <array>
#include <atomic>
#include <cstring>
#include <stdexcept>

namespace stickslip::testing {

enum class FaultKind { kWrite = 0, kSync = 1, kLock = 2 };
inline constexpr std::array<FaultKind, 3> kFaultKinds = {FaultKind::kWrite, FaultKind::kSync,
                                                         FaultKind::kLock};
inline const char* to_string(FaultKind k) noexcept {
  switch (k) {
    case FaultKind::kWrite: return "write";
    case FaultKind::kSync: return "sync";
    case FaultKind::kLock: return "lock";
  }
  return "?";
}

class FaultVfs {
 public:
  FaultVfs() {
    base_ = sqlite3_vfs_find(nullptr);
    if (base_ == nullptr || instance() != nullptr) throw std::logic_error("FaultVfs: one at a time");
    vfs_ = *base_;
    vfs_.szOsFile = static_cast<int>(sizeof(File)) + base_->szOsFile;
    vfs_.zName = "stickslip-fault";
    vfs_.pNext = nullptr;
    vfs_.xOpen = &FaultVfs::open;
    instance() = this;
    sqlite3_vfs_register(&vfs_, /*makeDflt=*/1);
  }
  /// Close every connection opened through the shim first.
  ~FaultVfs() {
    sqlite3_vfs_unregister(&vfs_);
    sqlite3_vfs_register(base_, 1);
    instance() = nullptr;
  }
  FaultVfs(const FaultVfs&) = delete;
  FaultVfs& operator=(const FaultVfs&) = delete;

  /// 0: writes work; otherwise every write, truncate and sync fails with this code.
  void fail_writes(int code) { code_.store(code); }

  /// The n-th call (n >= 1) of kind from now fails with code (0: the kind's default); with
  /// persist, every later call of that kind fails too, until disarm(). Replaces an earlier arm.
  void arm(FaultKind kind, long n, bool persist = false, int code = 0) {
    armed_.store(-1);
    const auto k = static_cast<std::size_t>(kind);
    arm_code_.store(code);
    arm_persist_.store(persist);
    arm_at_.store(calls_[k].load() + n);
    armed_.store(static_cast<int>(k));
  }
  void disarm() { armed_.store(-1); }

  /// Calls of a kind since construction (or reset_counts()), failed ones included.
  long calls(FaultKind kind) const { return calls_[static_cast<std::size_t>(kind)].load(); }
  /// Calls of a kind that the shim failed.
  long injected(FaultKind kind) const { return injected_[static_cast<std::size_t>(kind)].load(); }
  /// Calls that failed so far, of every kind.
  long failures() const { return injected(FaultKind::kWrite) + injected(FaultKind::kSync) +
                                 injected(FaultKind::kLock); }
  /// Called on every injected failure (from the failing call's thread), e.g. to log it.
  using InjectHook = void (*)(FaultKind kind, int code, long call);
  void on_inject(InjectHook hook) { hook_.store(hook); }

  void reset_counts() {
    disarm();
    for (auto& c : calls_) c.store(0);
    for (auto& c : injected_) c.store(0);
  }

 private:
  struct File {
    sqlite3_file base;   // pMethods = our methods
    sqlite3_file* real;  // the wrapped file, stored right after this struct
  };
  static FaultVfs*& instance() {
    static FaultVfs* p = nullptr;
    return p;
  }
  static sqlite3_file* real(sqlite3_file* f) { return reinterpret_cast<File*>(f)->real; }

  /// Counts a call of kind; the code to fail it with, or 0.
  static int fault(FaultKind kind, int default_code) {
    FaultVfs& v = *instance();
    const auto k = static_cast<std::size_t>(kind);
    const long n = v.calls_[k].fetch_add(1) + 1;
    int code = 0;
    if (v.armed_.load() == static_cast<int>(k)) {
      const long at = v.arm_at_.load();
      if (n == at || (n > at && v.arm_persist_.load())) {
        code = v.arm_code_.load();
        if (code == 0) code = default_code;
      }
    }
    if (code == 0 && kind != FaultKind::kLock) code = v.code_.load();
    if (code != 0) {
      v.injected_[k].fetch_add(1);
      if (const InjectHook hook = v.hook_.load()) hook(kind, code, n);
    }
    return code;
  }

  static int open(sqlite3_vfs*, sqlite3_filename name, sqlite3_file* file, int flags, int* out) {
    auto* f = reinterpret_cast<File*>(file);
    f->real = reinterpret_cast<sqlite3_file*>(f + 1);
    std::memset(f->real, 0, static_cast<std::size_t>(instance()->base_->szOsFile));
    f->base.pMethods = nullptr;
    const int rc = instance()->base_->xOpen(instance()->base_, name, f->real, flags, out);
    if (f->real->pMethods != nullptr) f->base.pMethods = &methods();
    return rc;
  }

  static const sqlite3_io_methods& methods() {
    static const sqlite3_io_methods m = {
        3,
        [](sqlite3_file* f) { return real(f)->pMethods->xClose(real(f)); },
        [](sqlite3_file* f, void* b, int n, sqlite3_int64 o) {
          return real(f)->pMethods->xRead(real(f), b, n, o);
        },
        [](sqlite3_file* f, const void* b, int n, sqlite3_int64 o) {
          if (const int c = fault(FaultKind::kWrite, SQLITE_IOERR_WRITE)) return c;
          return real(f)->pMethods->xWrite(real(f), b, n, o);
        },
        [](sqlite3_file* f, sqlite3_int64 n) {
          if (const int c = fault(FaultKind::kWrite, SQLITE_IOERR_TRUNCATE)) return c;
          return real(f)->pMethods->xTruncate(real(f), n);
        },
        [](sqlite3_file* f, int flags) {
          if (const int c = fault(FaultKind::kSync, SQLITE_IOERR_FSYNC)) return c;
          return real(f)->pMethods->xSync(real(f), flags);
        },
        [](sqlite3_file* f, sqlite3_int64* n) { return real(f)->pMethods->xFileSize(real(f), n); },
        [](sqlite3_file* f, int l) {
          if (const int c = fault(FaultKind::kLock, SQLITE_IOERR_LOCK)) return c;
          return real(f)->pMethods->xLock(real(f), l);
        },
        [](sqlite3_file* f, int l) { return real(f)->pMethods->xUnlock(real(f), l); },
        [](sqlite3_file* f, int* r) { return real(f)->pMethods->xCheckReservedLock(real(f), r); },
        [](sqlite3_file* f, int op, void* a) {
          return real(f)->pMethods->xFileControl(real(f), op, a);
        },
        [](sqlite3_file* f) { return real(f)->pMethods->xSectorSize(real(f)); },
        [](sqlite3_file* f) { return real(f)->pMethods->xDeviceCharacteristics(real(f)); },
        [](sqlite3_file* f, int pg, int sz, int ext, void volatile** p) {
          return real(f)->pMethods->xShmMap(real(f), pg, sz, ext, p);
        },
        [](sqlite3_file* f, int off, int n, int flags) {
          if ((flags & SQLITE_SHM_LOCK) != 0)
            if (const int c = fault(FaultKind::kLock, SQLITE_IOERR_SHMLOCK)) return c;
          return real(f)->pMethods->xShmLock(real(f), off, n, flags);
        },
        [](sqlite3_file* f) { real(f)->pMethods->xShmBarrier(real(f)); },
        [](sqlite3_file* f, int del) { return real(f)->pMethods->xShmUnmap(real(f), del); },
        [](sqlite3_file* f, sqlite3_int64 o, int n, void** p) {
          return real(f)->pMethods->xFetch(real(f), o, n, p);
        },
        [](sqlite3_file* f, sqlite3_int64 o, void* p) {
          return real(f)->pMethods->xUnfetch(real(f), o, p);
        },
    };
    return m;
  }

  sqlite3_vfs* base_ = nullptr;
  sqlite3_vfs vfs_{};
  std::atomic<int> code_{0};
  std::atomic<int> armed_{-1};  // the armed kind, or -1
  std::atomic<long> arm_at_{0};
  std::atomic<bool> arm_persist_{false};
  std::atomic<int> arm_code_{0};
  std::array<std::atomic<long>, 3> calls_{};
  std::array<std::atomic<long>, 3> injected_{};
  std::atomic<InjectHook> hook_{nullptr};
};

}  // namespace stickslip::testing
