#pragma once
// Thread priorities of stickslipd (Linux): nice is per thread, and threads inherit the nice value
// of the thread that creates them (so the OpenMP team of a study inherits its worker's).

#include <string>

namespace stickslip::server {

/// Adds increment (0..19) to the nice value of the calling thread, capped at 19; 0 changes
/// nothing. Returns false and sets *why (naming the value) when the increment is out of range or
/// the system refuses.
bool lower_thread_priority(int increment, std::string* why);

/// Asks the scheduler (Linux >= 6.12, EEVDF custom slices: sched_attr.sched_runtime of a
/// SCHED_OTHER thread) to run the calling thread in slices of slice_us microseconds (the kernel
/// clamps to [100, 100000]), keeping its nice value. A short slice does not change the thread's
/// share of the CPU (its nice value does that), only how often it gets it: a low-priority thread
/// with 0.1 ms slices is picked every few ms instead of every few tens. 0 = the default slice.
/// Returns false and sets *why when the kernel refuses (older kernels: ignore it).
bool set_thread_slice(int slice_us, std::string* why);

/// The nice value of the calling thread.
int thread_nice();

}  // namespace stickslip::server
