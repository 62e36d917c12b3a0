#include "stickslip/server/priority.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
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

bool set_thread_slice(int slice_us, std::string* why) {
  if (slice_us == 0) return true;
  if (slice_us < 0) {
    if (why != nullptr) *why = "slice must be >= 0 us, got " + std::to_string(slice_us);
    return false;
  }
  // struct sched_attr of linux/sched/types.h (SCHED_ATTR_SIZE_VER1); glibc 2.36 has no wrapper.
  struct {
    std::uint32_t size, sched_policy;
    std::uint64_t sched_flags;
    std::int32_t sched_nice;
    std::uint32_t sched_priority;
    std::uint64_t sched_runtime, sched_deadline, sched_period;
    std::uint32_t sched_util_min, sched_util_max;
  } attr{};
  attr.size = sizeof attr;
  attr.sched_policy = 0;  // SCHED_OTHER
  attr.sched_nice = thread_nice();
  attr.sched_runtime = static_cast<std::uint64_t>(slice_us) * 1000;  // [ns]
  if (::syscall(SYS_sched_setattr, this_thread_id(), &attr, 0u) != 0) {
    if (why != nullptr) *why = std::string("sched_setattr(slice ") + std::to_string(slice_us) +
                               " us): " + std::strerror(errno);
    return false;
  }
  return true;
}

}  // namespace stickslip::server
