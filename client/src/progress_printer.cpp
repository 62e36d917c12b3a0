#include "progress_printer.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>

namespace stickslip::client {

std::function<void(const diagnosis::Progress&)> progress_printer(bool quiet, double* interval) {
  if (quiet) return {};
  const bool tty = isatty(STDERR_FILENO) != 0;
  *interval = tty ? 0.5 : 5.0;
  return [tty](const diagnosis::Progress& p) {
    char left[64] = "";
    if (std::isfinite(p.seconds_left) && p.phase != "done")
      std::snprintf(left, sizeof left, ", about %.0f s left", p.seconds_left);
    const std::string item = p.item.empty() ? "" : " " + p.item;
    std::fprintf(stderr, "%s[%s]%s: %d of ~%d evaluations, %.0f s%s%s", tty ? "\r\033[K" : "",
                 p.phase.c_str(), item.c_str(), p.evaluations, p.estimated_total, p.seconds, left,
                 tty && p.phase != "done" ? "" : "\n");
    std::fflush(stderr);
  };
}

}  // namespace stickslip::client
