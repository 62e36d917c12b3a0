// The launcher backend: one launched MPI job per study, its runs read back from rank 0's
// standard output (launcher.h).
#include "stickslip/studies/launcher.h"

#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <optional>
#include <stdexcept>

#include "stickslip/common/text.h"
#include "stickslip/studies/wire.h"
#include "stream.h"

extern char** environ;

namespace stickslip::studies {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

// Boost.Process would need Boost.Filesystem, which is not among our dependencies; the spawn
// is posix_spawn (a new process group, default signals, no inherited descriptors).
struct Child {
  pid_t pid = -1;
  int in = -1, out = -1, err = -1;  // our ends: its stdin, stdout, stderr
};

void close_fd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

Child spawn(const LauncherOptions& o) {
  int p_in[2], p_out[2], p_err[2];
  if (::pipe2(p_in, O_CLOEXEC) != 0 || ::pipe2(p_out, O_CLOEXEC) != 0 ||
      ::pipe2(p_err, O_CLOEXEC) != 0)
    throw ExecutorError(std::string("cannot create pipes for the launcher: ") +
                        std::strerror(errno));
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, p_in[0], 0);
  posix_spawn_file_actions_adddup2(&fa, p_out[1], 1);
  posix_spawn_file_actions_adddup2(&fa, p_err[1], 2);
  posix_spawn_file_actions_addclosefrom_np(&fa, 3);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  for (int s : {SIGTERM, SIGINT, SIGPIPE, SIGHUP, SIGUSR1, SIGUSR2}) sigaddset(&defaults, s);
  posix_spawnattr_setsigmask(&attr, &none);  // a server blocks SIGTERM in every thread
  posix_spawnattr_setsigdefault(&attr, &defaults);
  posix_spawnattr_setpgroup(&attr, 0);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK |
                                      POSIX_SPAWN_SETSIGDEF);
  // The prefix is the operator's shell words; our arguments follow as "$@", never re-split.
  const std::string script = "exec " + o.command + " \"$@\"";
  const std::string program = o.program.string();
  std::vector<const char*> argv = {"/bin/sh", "-c", script.c_str(), "stickslip-launcher",
                                   program.c_str(), "study", "compute", nullptr};
  Child c;
  const int rc = ::posix_spawn(&c.pid, "/bin/sh", &fa, &attr,
                               const_cast<char* const*>(argv.data()), environ);
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&attr);
  ::close(p_in[0]);
  ::close(p_out[1]);
  ::close(p_err[1]);
  c.in = p_in[1];
  c.out = p_out[0];
  c.err = p_err[0];
  if (rc != 0) {
    close_fd(c.in);
    close_fd(c.out);
    close_fd(c.err);
    throw ExecutorError("cannot start the launcher '" + o.command + "': " + std::strerror(rc));
  }
  ::fcntl(c.in, F_SETFL, ::fcntl(c.in, F_GETFL) | O_NONBLOCK);
  return c;
}

// The launcher's last meaningful lines (Open MPI frames its messages with lines of dashes).
class Tail {
 public:
  void add(const std::string& line) {
    if (line.find_first_not_of(" -\t\r") == std::string::npos) return;
    lines_.push_back(line);
    if (lines_.size() > 6) lines_.pop_front();
  }
  std::string text() const {
    return common::join(std::vector<std::string>(lines_.begin(), lines_.end()), " / ");
  }

 private:
  std::deque<std::string> lines_;
};

/// One launched job: spawn, pump its streams, end it, say how it ended.
class LaunchedJob {
 public:
  LaunchedJob(const LauncherOptions& o, const ComputeRequest& req, const RecordSink& sink,
              const StopFn& stop)
      : o_(o), req_(req), sink_(sink), stop_(stop) {}

  void run() {
    wire::Task t;
    t.study_id = req_.study_id;
    t.spec_json = req_.spec->canonical_json();
    t.limits = req_.spec->limits();
    t.spec_dir = fs::absolute(req_.spec_dir).string();
    t.pending = req_.pending;
    t.threads = req_.threads;
    t.chunk_deadline_s = req_.chunk_deadline_s;
    task_ = stream::frame_bytes(json::binary(wire::encode_task(t)));
    child_ = spawn(o_);
    pump();
    const int status = reap();
    if (stopping_) return;  // we asked it to stop: whatever it returned is committed
    if (done_ && WIFEXITED(status) && WEXITSTATUS(status) == 0 && received_ == req_.pending.size())
      return;
    throw ExecutorError(failure(status));
  }

 private:
  void pump() {
    std::uint8_t buf[1 << 16];
    while (child_.out >= 0 || child_.err >= 0) {
      pollfd fds[3] = {{child_.out, POLLIN, 0}, {child_.err, POLLIN, 0},
                       {sent_ < task_.size() ? child_.in : -1, POLLOUT, 0}};
      if (::poll(fds, 3, 100) < 0 && errno != EINTR) break;
      if (fds[0].revents != 0) read_from(child_.out, buf, sizeof buf, true);
      if (fds[1].revents != 0) read_from(child_.err, buf, sizeof buf, false);
      if (fds[2].revents != 0) send_task();
      watch();
    }
  }

  void read_from(int& fd, std::uint8_t* buf, std::size_t size, bool frames) {
    const ssize_t n = ::read(fd, buf, size);
    if (n < 0 && errno == EINTR) return;
    if (n <= 0) {
      close_fd(fd);
      if (!frames && !line_.empty()) output(line_);
      return;
    }
    if (!frames) {
      for (ssize_t i = 0; i < n; ++i) {
        if (buf[i] != '\n') {
          line_.push_back(static_cast<char>(buf[i]));
        } else {
          output(line_);
          line_.clear();
        }
      }
      return;
    }
    reader_.feed(buf, static_cast<std::size_t>(n));
    try {
      while (auto doc = reader_.next()) on_frame(*doc);
    } catch (const wire::WireError& e) {  // not our stream: end the job
      if (!error_) error_ = std::string("rank 0's output is not a stickslip stream: ") + e.what();
      terminate();
      close_fd(fd);
    }
  }

  void output(const std::string& line) {
    tail_.add(line);
    if (o_.on_output) o_.on_output(line);
  }

  void on_frame(const json& doc) {
    last_frame_ = Clock::now();
    const std::string type = doc.value("t", "");
    if (type == "hello") {
      hello_ = true;
    } else if (type == "runs") {
      const auto& bin = doc.at("runs").get_binary();
      std::vector<store::RunRecord> recs = wire::decode_runs(bin.data(), bin.size(), req_.study_id);
      received_ += recs.size();
      sink_(std::move(recs));
    } else if (type == "error") {
      error_ = doc.value("message", "the job reported an error");
    } else if (type == "done") {
      done_ = true;
      if (req_.batched != nullptr) *req_.batched += doc.value("batched", std::int64_t{0});
    }
  }

  void send_task() {
    const ssize_t n = ::write(child_.in, task_.data() + sent_, task_.size() - sent_);
    if (n > 0) sent_ += static_cast<std::size_t>(n);
    if (n < 0 && errno != EAGAIN && errno != EINTR) sent_ = task_.size();  // it is gone
  }

  /// A stop closes the job's input (it returns its chunks and exits); the grace, the silence
  /// limit and the kill that follows.
  void watch() {
    const auto now = Clock::now();
    if (!stopping_ && stop_()) {
      stopping_ = true;
      stop_at_ = now;
      close_fd(child_.in);
    }
    if (stopping_ && now - stop_at_ > o_.stop_grace) terminate();
    if (hello_ && !stopping_ && now - last_frame_ > o_.silence) {
      error_ = "rank 0 of the job sent nothing for " +
               std::to_string(std::chrono::duration_cast<std::chrono::seconds>(o_.silence).count()) +
               " s (hung or cut off)";
      terminate();
    }
    if (term_at_ && now - *term_at_ > std::chrono::seconds(5)) ::kill(-child_.pid, SIGKILL);
  }

  void terminate() {
    if (term_at_) return;
    term_at_ = Clock::now();
    ::kill(-child_.pid, SIGTERM);
  }

  int reap() {
    close_fd(child_.in);
    int status = 0;
    const auto t0 = Clock::now();
    while (::waitpid(child_.pid, &status, WNOHANG) == 0) {
      if (Clock::now() - t0 > std::chrono::seconds(10)) ::kill(-child_.pid, SIGKILL);
      ::usleep(10000);
    }
    ::kill(-child_.pid, SIGKILL);  // anything of the job still in its process group
    return status;
  }

  std::string failure(int status) const {
    std::string how;
    if (WIFEXITED(status))
      how = "exited with status " + std::to_string(WEXITSTATUS(status));
    else if (WIFSIGNALED(status))
      how = "was killed by signal " + std::to_string(WTERMSIG(status));
    std::string why = "the MPI job ('" + o_.command + "') " + how + " after returning " +
                      std::to_string(received_) + " of " + std::to_string(req_.pending.size()) +
                      " runs";
    if (error_) why += ": " + *error_;
    const std::string tail = tail_.text();
    if (!tail.empty()) why += (error_ ? "; launcher: " : ": ") + tail;
    return why;
  }

  const LauncherOptions& o_;
  const ComputeRequest& req_;
  const RecordSink& sink_;
  const StopFn& stop_;
  std::vector<std::uint8_t> task_;
  std::size_t sent_ = 0, received_ = 0;
  Child child_;
  stream::FrameReader reader_;
  std::string line_;
  Tail tail_;
  bool hello_ = false, done_ = false, stopping_ = false;
  std::optional<std::string> error_;
  Clock::time_point last_frame_ = Clock::now(), stop_at_;
  std::optional<Clock::time_point> term_at_;
};

class LauncherExecutor final : public Executor {
 public:
  explicit LauncherExecutor(LauncherOptions o) : o_(std::move(o)) {}
  void compute(const ComputeRequest& req, const RecordSink& sink, const StopFn& stop) override {
    if (req.pending.empty()) return;
    // A job that went away makes our writes fail with EPIPE; this thread never takes SIGPIPE.
    sigset_t pipe_only;
    sigemptyset(&pipe_only);
    sigaddset(&pipe_only, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &pipe_only, nullptr);
    LaunchedJob(o_, req, sink, stop).run();
  }
  std::string describe() const override { return "launcher '" + o_.command + "'"; }

 private:
  LauncherOptions o_;
};

}  // namespace

bool LauncherOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  std::error_code ec;
  if (program.empty() || !fs::is_regular_file(program, ec) || ::access(program.c_str(), X_OK) != 0)
    fail("launcher program: no executable at '" + program.string() + "'");
  if (command.find_first_of("\n\r") != std::string::npos)
    fail("launcher: must be one line, got '" + command + "'");
  if (stop_grace.count() < 0)
    fail("stop_grace: must be >= 0 ms, got " + std::to_string(stop_grace.count()));
  if (silence.count() < 1000)
    fail("silence: must be >= 1000 ms, got " + std::to_string(silence.count()));
  return ok;
}

std::shared_ptr<Executor> launcher_executor(LauncherOptions options) {
  if (std::vector<std::string> errors; !options.IsValid(&errors))
    throw std::invalid_argument(common::join(errors, "; "));
  return std::make_shared<LauncherExecutor>(std::move(options));
}

fs::path sibling_program(const std::string& name) {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec && fs::is_regular_file(self.parent_path() / name, ec))
    return self.parent_path() / name;
  if (const char* path = std::getenv("PATH")) {
    std::string dirs = path;
    for (std::size_t a = 0; a <= dirs.size();) {
      const std::size_t b = std::min(dirs.find(':', a), dirs.size());
      const fs::path candidate = fs::path(dirs.substr(a, b - a)) / name;
      if (b > a && ::access(candidate.c_str(), X_OK) == 0) return candidate;
      a = b + 1;
    }
  }
  return ec ? fs::path(name) : self.parent_path() / name;
}

}  // namespace stickslip::studies
