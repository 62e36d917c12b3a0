#include "stickslip/common/gnuplot.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <stdexcept>

namespace stickslip::common {

int run_gnuplot(const GnuplotCall& call) {
  // Everything the child needs is prepared before fork: between fork and exec it may only call
  // async-signal-safe functions (the parent can be multithreaded).
  const std::string exe = call.executable, script = call.script.string();
  const std::string workdir = call.workdir.string();
  // Absolute, so that the child can remove it again after its chdir.
  const std::string log = call.log.empty() ? std::string() : std::filesystem::absolute(call.log).string();
  char* argv[] = {const_cast<char*>(exe.c_str()), const_cast<char*>(script.c_str()), nullptr};
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("cannot start gnuplot: fork failed");
  if (pid == 0) {
    if (!log.empty()) {
      const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
      if (fd < 0 || dup2(fd, STDERR_FILENO) < 0) _exit(126);
      if (call.log_stdout && dup2(fd, STDOUT_FILENO) < 0) _exit(126);
    }
    if (!workdir.empty() && chdir(workdir.c_str()) != 0) _exit(126);
    execvp(argv[0], argv);
    if (!log.empty()) unlink(log.c_str());
    _exit(kGnuplotNotFound);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw std::runtime_error("waitpid on gnuplot failed");
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return WIFSIGNALED(status) ? 128 + WTERMSIG(status) : 126;
}

}  // namespace stickslip::common
