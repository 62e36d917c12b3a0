#pragma once
// The diagnosis' and the validation's progress on a terminal (private to the client): the
// phase, the models or candidates in work, evaluations done of the estimated total, and the
// time left. On a terminal one line is rewritten in place; otherwise a line every few seconds.
#include <functional>

#include "stickslip/diagnosis/diagnose.h"

namespace stickslip::client {

/// The callback for DiagnoseOptions::progress (writes to stderr); *interval receives the
/// reporting interval it wants [s]. quiet: an empty callback.
std::function<void(const diagnosis::Progress&)> progress_printer(bool quiet, double* interval);

}  // namespace stickslip::client
