// The single-writer lock of a store (writer_lock.h).
#include "stickslip/store/writer_lock.h"

#include <errno.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <map>
#include <mutex>
#include <thread>
#include <utility>

#include <nlohmann/json.hpp>

namespace stickslip::store {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string where(const fs::path& db) { return "stickslip store '" + db.string() + "'"; }

std::string this_host() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

std::string this_program() {
  char buf[64] = {};
  const int fd = ::open("/proc/self/comm", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "unknown";
  const ssize_t n = ::read(fd, buf, sizeof buf - 1);
  ::close(fd);
  std::string s(buf, n > 0 ? static_cast<std::size_t>(n) : 0);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s.empty() ? "unknown" : s;
}

std::string to_text(const LockHolder& h) {
  return json{{"pid", h.pid}, {"host", h.host}, {"program", h.program}, {"since", h.since},
              {"url", h.url}}
             .dump() +
         "\n";
}

std::optional<LockHolder> from_text(const std::string& text) {
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return std::nullopt;
  LockHolder h;
  h.pid = j.value("pid", 0L);
  h.host = j.value("host", "");
  h.program = j.value("program", "");
  h.since = j.value("since", "");
  h.url = j.value("url", "");
  return h;
}

std::string read_all(int fd) {
  std::string out;
  char buf[512];
  off_t at = 0;
  while (true) {
    const ssize_t n = ::pread(fd, buf, sizeof buf, at);
    if (n <= 0) break;
    out.append(buf, static_cast<std::size_t>(n));
    at += n;
  }
  return out;
}

using Key = std::pair<dev_t, ino_t>;

}  // namespace

/// One held lock of this process: the descriptor that carries the flock and the description.
struct WriterLock::File {
  int fd = -1;
  fs::path path;
  mutable std::mutex mu;
  LockHolder holder;
  bool checked = false;

  ~File() {
    // Clear the description before the kernel drops the lock with the descriptor.
    if (::ftruncate(fd, 0) != 0) {
    }
    ::close(fd);
  }
  void write() const {  // under mu
    const std::string text = to_text(holder);
    if (::pwrite(fd, text.data(), text.size(), 0) == static_cast<ssize_t>(text.size()))
      if (::ftruncate(fd, static_cast<off_t>(text.size())) != 0) {
      }
  }
};

namespace {

/// The locks this process holds, by the lock file's identity. A process-wide table on purpose
/// (like SQLite's own table of inode locks): flock conflicts between two descriptors of one
/// process, so every connection of the process must share the one descriptor that holds it.
std::mutex& registry_mutex() {
  static std::mutex mu;
  return mu;
}
std::map<Key, std::weak_ptr<WriterLock::File>>& registry() {
  static std::map<Key, std::weak_ptr<WriterLock::File>> held;
  return held;
}

std::optional<Key> key_of(int fd) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return std::nullopt;
  return Key{st.st_dev, st.st_ino};
}

/// The holder of the lock on the file open at fd, when this process holds it.
std::shared_ptr<WriterLock::File> held_here(int fd) {
  const auto key = key_of(fd);
  if (!key) return nullptr;
  auto& reg = registry();
  const auto it = reg.find(*key);
  if (it == reg.end()) return nullptr;
  auto file = it->second.lock();
  if (!file) reg.erase(it);
  return file;
}

[[noreturn]] void throw_locked(const fs::path& db, int fd) {
  const std::optional<LockHolder> h = from_text(read_all(fd));
  const std::string who =
      h ? h->describe()
        : "another process (its description in '" + WriterLock::lock_path(db).string() +
              "' could not be read)";
  throw StoreLockedError(where(db) + ": another process writes to this store: " + who +
                             ". A store has one writer at a time (docs/store.md, One writer); "
                             "read-only commands and `sqlite3 -readonly` may still read it",
                         h);
}

}  // namespace

std::string LockHolder::describe() const {
  std::string s = (program.empty() ? std::string("a process") : program) + " (pid " +
                  std::to_string(pid) + " on host " + (host.empty() ? "?" : host);
  if (!since.empty()) s += ", since " + since;
  if (!url.empty()) s += ", serving " + url;
  return s + ")";
}

fs::path WriterLock::lock_path(const fs::path& db) { return fs::path(db.string() + ".lock"); }

WriterLock::WriterLock(std::shared_ptr<File> file) noexcept : file_(std::move(file)) {}
WriterLock::WriterLock(WriterLock&&) noexcept = default;
WriterLock& WriterLock::operator=(WriterLock&&) noexcept = default;
WriterLock::~WriterLock() {
  if (!file_) return;
  std::lock_guard lock(registry_mutex());  // the last owner's ~File runs under the table's lock
  file_.reset();
}

WriterLock WriterLock::acquire(const fs::path& db, const std::string& program) {
  const fs::path path = lock_path(db);
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0)
    throw StoreError(where(db) + ": cannot open its writer lock '" + path.string() +
                     "': " + std::strerror(errno));
  std::lock_guard lock(registry_mutex());
  if (auto file = held_here(fd)) {
    ::close(fd);  // a second descriptor of the lock file; the flock stays with the first
    if (!program.empty()) {
      std::lock_guard g(file->mu);
      file->holder.program = program;
      file->write();
    }
    return WriterLock(std::move(file));
  }
  // A reader of the description (holder()) takes a shared lock for an instant: try a few times.
  int rc = -1;
  for (int attempt = 0; attempt < 5 && rc != 0; ++attempt) {
    rc = ::flock(fd, LOCK_EX | LOCK_NB);
    if (rc != 0 && errno != EWOULDBLOCK && errno != EINTR) break;
    if (rc != 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (rc != 0) {
    const int err = errno;
    if (err == EWOULDBLOCK || err == EINTR) {
      try {
        throw_locked(db, fd);
      } catch (...) {
        ::close(fd);
        throw;
      }
    }
    ::close(fd);
    throw StoreError(where(db) + ": cannot lock '" + path.string() + "': " + std::strerror(err));
  }
  auto file = std::make_shared<File>();
  file->fd = fd;
  file->path = path;
  file->holder = {static_cast<long>(::getpid()), this_host(),
                  program.empty() ? this_program() : program, utc_now_iso8601(), ""};
  file->write();
  registry()[*key_of(fd)] = file;
  return WriterLock(std::move(file));
}

std::optional<LockHolder> WriterLock::holder(const fs::path& db) {
  const int fd = ::open(lock_path(db).c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  {
    std::lock_guard lock(registry_mutex());
    if (auto file = held_here(fd)) {
      ::close(fd);
      std::lock_guard g(file->mu);
      return file->holder;
    }
  }
  std::optional<LockHolder> out;
  if (::flock(fd, LOCK_SH | LOCK_NB) == 0) {
    ::flock(fd, LOCK_UN);  // nobody holds it
  } else {
    out = from_text(read_all(fd));
    if (!out) out = LockHolder{0, "", "unknown", "", ""};
  }
  ::close(fd);
  return out;
}

void WriterLock::set_url(const std::string& url) {
  std::lock_guard g(file_->mu);
  file_->holder.url = url;
  file_->write();
}

bool WriterLock::checked() const {
  std::lock_guard g(file_->mu);
  return file_->checked;
}

void WriterLock::mark_checked() {
  std::lock_guard g(file_->mu);
  file_->checked = true;
}

}  // namespace stickslip::store
