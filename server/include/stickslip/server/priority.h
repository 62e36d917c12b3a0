#pragma once
// Thread priorities of stickslipd (Linux): nice is per thread, and threads inherit the nice value
// of the thread that creates them (so the OpenMP team of a study inherits its worker's).

#include <string>

namespace stickslip::server {

/// Adds increment (0..19) to the nice value of the calling thread, capped at 19; 0 changes
/// nothing. Returns false and sets *why (naming the value) when the increment is out of range or
/// the system refuses.
bool lower_thread_priority(int increment, std::string* why);

/// The nice value of the calling thread.
int thread_nice();

}  // namespace stickslip::server
