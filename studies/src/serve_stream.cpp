// The launcher stream's frames (stream.h) and the launched job's side of it (serve_stream,
// launcher.h).
#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>

#include "stickslip/studies/launcher.h"
#include "stickslip/studies/wire.h"
#include "stream.h"

namespace stickslip::studies {
namespace stream {

bool write_all(int fd, const std::uint8_t* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

std::vector<std::uint8_t> frame_bytes(const nlohmann::json& doc) {
  const std::vector<std::uint8_t> body = nlohmann::json::to_msgpack(doc);
  std::vector<std::uint8_t> out(4 + body.size());
  const auto n = static_cast<std::uint32_t>(body.size());
  for (int i = 0; i < 4; ++i) out[i] = static_cast<std::uint8_t>(n >> (8 * i));
  std::memcpy(out.data() + 4, body.data(), body.size());
  return out;
}

bool FrameWriter::write(const nlohmann::json& doc) {
  const std::vector<std::uint8_t> bytes = frame_bytes(doc);
  std::lock_guard lock(mu_);
  if (broken_) return false;
  if (!write_all(fd_, bytes.data(), bytes.size())) broken_ = true;
  return !broken_;
}

bool FrameWriter::broken() const {
  std::lock_guard lock(mu_);
  return broken_;
}

void FrameReader::feed(const std::uint8_t* data, std::size_t size) {
  buf_.insert(buf_.end(), data, data + size);
}

std::optional<nlohmann::json> FrameReader::next() {
  if (buf_.size() - pos_ < 4) return std::nullopt;
  std::size_t n = 0;
  for (int i = 0; i < 4; ++i) n |= static_cast<std::size_t>(buf_[pos_ + i]) << (8 * i);
  if (n > kMaxFrame)
    throw wire::WireError("a frame of " + std::to_string(n) + " bytes: not a stickslip stream");
  if (buf_.size() - pos_ - 4 < n) return std::nullopt;
  nlohmann::json doc = wire::decode_json(buf_.data() + pos_ + 4, n);
  pos_ += 4 + n;
  if (pos_ == buf_.size()) {
    buf_.clear();
    pos_ = 0;
  } else if (pos_ > (std::size_t{1} << 20)) {
    buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(pos_));
    pos_ = 0;
  }
  return doc;
}

}  // namespace stream

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

/// Reads the one task frame of the stream; nullopt at end of input before a whole frame.
std::optional<json> read_task(int fd) {
  stream::FrameReader reader;
  std::uint8_t buf[1 << 16];
  while (true) {
    if (auto doc = reader.next()) return doc;
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return std::nullopt;
    reader.feed(buf, static_cast<std::size_t>(n));
  }
}

/// Until finished: end of input (or a broken output) sets stop; a heartbeat every second.
void watch_input(int in_fd, stream::FrameWriter& out, std::atomic<bool>& stop,
                 const std::atomic<bool>& finished) {
  auto last_beat = Clock::now();
  bool input_open = true;
  while (!finished.load()) {
    if (input_open) {
      pollfd p{in_fd, POLLIN, 0};
      if (::poll(&p, 1, 200) > 0) {
        std::uint8_t buf[4096];
        const ssize_t n = ::read(in_fd, buf, sizeof buf);
        if (n == 0 || (n < 0 && errno != EINTR)) {
          input_open = false;
          stop = true;
        }
      }
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    if (Clock::now() - last_beat >= std::chrono::seconds(1)) {
      if (!out.write(json{{"t", "beat"}})) stop = true;
      last_beat = Clock::now();
    }
  }
}

}  // namespace

int serve_stream(int in_fd, int out_fd, Executor& executor) {
  ::signal(SIGPIPE, SIG_IGN);  // a caller that went away is a failed write, not a signal
  stream::FrameWriter out(out_fd);
  std::optional<wire::LoadedTask> loaded;
  wire::Task task;
  try {
    const std::optional<json> doc = read_task(in_fd);
    if (!doc) throw wire::WireError("no task on standard input");
    if (!doc->is_binary()) throw wire::WireError("the first frame is not a task");
    task = wire::decode_task(doc->get_binary().data(), doc->get_binary().size());
    loaded.emplace(wire::load_task(task));
  } catch (const std::exception& e) {
    out.write(json{{"t", "error"}, {"message", std::string("bad task: ") + e.what()}});
    return 2;
  }
  out.write(json{{"t", "hello"}, {"backend", executor.describe()}});
  std::atomic<bool> stop{false}, finished{false};
  std::thread watcher([&] { watch_input(in_fd, out, stop, finished); });
  ComputeRequest req;
  req.study_id = task.study_id;
  req.spec = &loaded->spec;
  req.measured = loaded->measured ? &*loaded->measured : nullptr;
  req.spec_dir = task.spec_dir;
  req.pending = task.pending;
  req.threads = task.threads;
  req.chunk_deadline_s = task.chunk_deadline_s;
  std::atomic<std::int64_t> batched{0};
  req.batched = &batched;
  int code = 0;
  try {
    executor.compute(
        req,
        [&](std::vector<store::RunRecord>&& recs) {
          if (!out.write(json{{"t", "runs"}, {"runs", json::binary(wire::encode_runs(recs))}}))
            stop = true;
        },
        [&] { return stop.load(); });
    out.write(json{{"t", "done"}, {"batched", batched.load()}});
  } catch (const std::exception& e) {
    out.write(json{{"t", "error"}, {"message", e.what()}});
    std::fprintf(stderr, "stickslip study compute: %s\n", e.what());
    code = 1;
  }
  finished = true;
  watcher.join();
  return code;
}

}  // namespace stickslip::studies
