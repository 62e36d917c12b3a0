#pragma once
// The one way stickslip starts gnuplot (the nightly report's SVG plots, the diagnosis' PNG
// plots): fork + execvp, without a shell, so that no path or name in the call is ever
// interpreted by one.
#include <filesystem>
#include <string>

namespace stickslip::common {

struct GnuplotCall {
  std::string executable = "gnuplot";  ///< looked up on PATH (execvp)
  std::filesystem::path script;        ///< the script, relative to workdir when relative
  std::filesystem::path workdir;       ///< the child's working directory; empty: ours
  /// Receives gnuplot's stderr (created or truncated; relative to our working directory);
  /// empty: inherited. When gnuplot cannot be started the file is removed again.
  std::filesystem::path log;
  bool log_stdout = false;  ///< also send stdout to log (otherwise inherited)
};

/// gnuplot's exit status is 127 when the executable could not be started (not found).
inline constexpr int kGnuplotNotFound = 127;

/// Runs `<executable> <script>` and waits for it. Returns its exit status (0: success),
/// kGnuplotNotFound when it could not be started, 126 when the log could not be opened or
/// workdir entered, 128 + the signal when a signal ended it. Throws std::runtime_error when the
/// process cannot be created or waited for.
int run_gnuplot(const GnuplotCall& call);

}  // namespace stickslip::common
