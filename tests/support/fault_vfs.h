#pragma once
// Test support: an SQLite VFS shim that makes writes fail on demand, in the spirit of SQLite's
// own I/O-error tests. While a FaultVfs exists it is the process's default VFS (every connection
// opened meanwhile goes through it) and forwards everything to the VFS that was the default
// before; fail_writes(code) makes every later xWrite, xTruncate and xSync of every file fail
// with code (an SQLITE_IOERR_* or SQLITE_FULL) until fail_writes(0). Reads always work, as with
// a disk that went read-only or full.
#include <sqlite3.h>

#include <atomic>
#include <cstring>
#include <stdexcept>

namespace stickslip::testing {

class FaultVfs {
 public:
  FaultVfs() {
    base_ = sqlite3_vfs_find(nullptr);
    if (base_ == nullptr || instance() != nullptr)
      throw std::logic_error("FaultVfs: one at a time");
    vfs_ = *base_;
    vfs_.szOsFile = static_cast<int>(sizeof(File)) + base_->szOsFile;
    vfs_.zName = "stickslip-fault";
    vfs_.pNext = nullptr;
    vfs_.xOpen = &FaultVfs::open;
    instance() = this;
    sqlite3_vfs_register(&vfs_, /*makeDflt=*/1);
  }
  ~FaultVfs() {
    sqlite3_vfs_unregister(&vfs_);
    sqlite3_vfs_register(base_, 1);
    instance() = nullptr;
  }
  FaultVfs(const FaultVfs&) = delete;
  FaultVfs& operator=(const FaultVfs&) = delete;

  /// 0: writes work; otherwise every write, truncate and sync fails with this code.
  void fail_writes(int code) { code_.store(code); }
  /// Calls that failed so far.
  long failures() const { return failures_.load(); }

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
  static int fault() {
    const int code = instance()->code_.load();
    if (code != 0) instance()->failures_.fetch_add(1);
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
          if (const int c = fault()) return c;
          return real(f)->pMethods->xWrite(real(f), b, n, o);
        },
        [](sqlite3_file* f, sqlite3_int64 n) {
          if (const int c = fault()) return c;
          return real(f)->pMethods->xTruncate(real(f), n);
        },
        [](sqlite3_file* f, int flags) {
          if (const int c = fault()) return c;
          return real(f)->pMethods->xSync(real(f), flags);
        },
        [](sqlite3_file* f, sqlite3_int64* n) { return real(f)->pMethods->xFileSize(real(f), n); },
        [](sqlite3_file* f, int l) { return real(f)->pMethods->xLock(real(f), l); },
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
  std::atomic<long> failures_{0};
};

}  // namespace stickslip::testing
