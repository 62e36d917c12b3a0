#include "stickslip/server/priority.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace stickslip::server {
namespace {
id_t this_thread_id() { return static_cast<id_t>(::syscall(SYS_gettid)); }
}  // namespace

int thread_nice() {
  // PRIO_PROCESS with a thread id reads (and sets) that thread only on Linux.
  return ::getpriority(PRIO_PROCESS, this_thread_id());
}

bool lower_thread_priority(int increment, std::string* why) {
  if (increment == 0) return true;
  if (increment < 0 || increment > 19) {
    if (why != nullptr) *why = "nice increment must be in [0, 19], got " + std::to_string(increment);
    return false;
  }
  const id_t tid = this_thread_id();
  errno = 0;
  const int now = ::getpriority(PRIO_PROCESS, tid);
  if (now == -1 && errno != 0) {
    if (why != nullptr) *why = std::string("getpriority: ") + std::strerror(errno);
    return false;
  }
  const int target = std::min(19, now + increment);
  if (::setpriority(PRIO_PROCESS, tid, target) != 0) {
    if (why != nullptr)
      *why = "setpriority(" + std::to_string(target) + "): " + std::strerror(errno);
    return false;
  }
  return true;
}

}  // namespace stickslip::server
