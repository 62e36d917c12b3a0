// The fault VFS shim (tests/support/fault_vfs.h) in a real stickslipd or stickslip process:
// built as libstickslip_fault_vfs.so and loaded with LD_PRELOAD, it makes itself the process's
// default SQLite VFS before main() runs (the binaries link the system libsqlite3 dynamically, so
// the shim and the store share one SQLite). Nothing in the store or the binaries knows of it.
//
//   STICKSLIP_FAULT_VFS="KIND:N[:persist][:CODE]"  KIND write, sync or lock; the N-th call of
//       KIND after arming fails (with persist: every call from the N-th on) with SQLite code
//       CODE (default: the kind's I/O error, fault_vfs.h).
//   STICKSLIP_FAULT_VFS_ARM=signal  arm when the process receives SIGUSR2 (default: at start);
//       SIGUSR1 disarms (the disk works again). Arming and disarming only store atomics, which a
//       signal handler may do.
// Each injected failure writes one line to stderr ("libstickslip_fault_vfs: injected KIND error
// CODE at call N"). Without STICKSLIP_FAULT_VFS the library does nothing.
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "support/fault_vfs.h"

namespace {

using stickslip::testing::FaultKind;
using stickslip::testing::FaultVfs;

struct Plan {
  FaultKind kind = FaultKind::kWrite;
  long n = 1;
  bool persist = false;
  int code = 0;
};

FaultVfs* g_vfs = nullptr;
Plan g_plan;

/// One line on stderr per injected failure, so that a test can count them:
/// "libstickslip_fault_vfs: injected write error 778 at call 41".
void log_injection(FaultKind kind, int code, long call) {
  char line[128];
  const int n = std::snprintf(line, sizeof line,
                              "libstickslip_fault_vfs: injected %s error %d at call %ld\n",
                              stickslip::testing::to_string(kind), code, call);
  if (n > 0) (void)!::write(2, line, static_cast<std::size_t>(n));
}

void arm(int) { g_vfs->arm(g_plan.kind, g_plan.n, g_plan.persist, g_plan.code); }
void disarm(int) { g_vfs->disarm(); }

bool parse(const std::string& text, Plan& p) {
  std::size_t pos = 0;
  const auto next = [&]() -> std::string {
    const auto colon = text.find(':', pos);
    std::string field = text.substr(pos, colon == std::string::npos ? std::string::npos : colon - pos);
    pos = colon == std::string::npos ? text.size() : colon + 1;
    return field;
  };
  const std::string kind = next();
  if (kind == "write") p.kind = FaultKind::kWrite;
  else if (kind == "sync") p.kind = FaultKind::kSync;
  else if (kind == "lock") p.kind = FaultKind::kLock;
  else return false;
  const std::string n = next();
  p.n = std::strtol(n.c_str(), nullptr, 10);
  if (p.n < 1) return false;
  while (pos < text.size()) {
    const std::string f = next();
    if (f == "persist") p.persist = true;
    else p.code = std::atoi(f.c_str());
  }
  return true;
}

__attribute__((constructor)) void install() {
  const char* spec = std::getenv("STICKSLIP_FAULT_VFS");
  if (spec == nullptr || *spec == '\0') return;
  if (!parse(spec, g_plan)) {
    std::fprintf(stderr, "libstickslip_fault_vfs: bad STICKSLIP_FAULT_VFS '%s'\n", spec);
    std::_Exit(99);
  }
  g_vfs = new FaultVfs;  // for the life of the process
  g_vfs->on_inject(&log_injection);
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_flags = SA_RESTART;
  sa.sa_handler = &arm;
  sigaction(SIGUSR2, &sa, nullptr);
  sa.sa_handler = &disarm;
  sigaction(SIGUSR1, &sa, nullptr);
  const char* when = std::getenv("STICKSLIP_FAULT_VFS_ARM");
  if (when == nullptr || std::strcmp(when, "signal") != 0) arm(0);
}

}  // namespace
