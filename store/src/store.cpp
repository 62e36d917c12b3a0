// The SQLite store (store.h; schema in schema.cpp, documented in docs/store.md): ids, hashes and
// states, opening a Store, and what its study and diagnosis records share. The records
// themselves: studies.cpp, diagnoses.cpp, runs.cpp (read side) and run_writer.cpp (write side).
#include "stickslip/store/store.h"

#include <cinttypes>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <random>

#include <nlohmann/json.hpp>

#include "records.h"

namespace stickslip::store {

std::string param_hash(std::string_view canonical_json) {
  std::uint64_t h = 0xcbf29ce484222325ULL;  // FNV-1a 64-bit offset basis
  for (const char c : canonical_json) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;  // FNV-1a 64-bit prime
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, h);
  return buf;
}

StoreFault StoreError::fault() const noexcept {
  switch (code_ & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED: return StoreFault::kBusy;
    case SQLITE_IOERR:
    case SQLITE_CORRUPT:
    case SQLITE_FULL:
    case SQLITE_CANTOPEN:
    case SQLITE_NOTADB:
    case SQLITE_READONLY:
    case SQLITE_PROTOCOL:
    case SQLITE_NOMEM: return StoreFault::kPersistent;
    default: return StoreFault::kNone;
  }
}

std::string new_job_id(const std::string& prefix) {
  // The last id made by this process, as (ms, low): a new id sorts after it even when the clock
  // has not moved on (or went back). A process-wide state on purpose: ids must be ordered
  // across every Store of the process. The random low digits keep ids of separate processes
  // apart.
  static std::mutex mu;
  static std::uint64_t last_ms = 0;
  static std::uint32_t last_low = 0;
  std::uint64_t ms = static_cast<std::uint64_t>(
                         std::chrono::duration_cast<std::chrono::milliseconds>(
                             std::chrono::system_clock::now().time_since_epoch())
                             .count()) &
                     0xffffffffffffULL;
  std::uint32_t low = std::random_device{}();
  {
    std::lock_guard lock(mu);
    if (ms < last_ms || (ms == last_ms && low <= last_low)) {
      ms = last_ms;
      low = last_low + 1;
      if (low == 0) ++ms;  // wrapped: the next millisecond's first id
    }
    last_ms = ms;
    last_low = low;
  }
  char buf[48];
  std::snprintf(buf, sizeof buf, "%s-%012" PRIx64 "%08" PRIx32, prefix.c_str(), ms, low);
  return buf;
}

std::string new_study_id() { return new_job_id("st"); }
std::string new_diagnosis_id() { return new_job_id("dg"); }

StoreCheck check_store(const std::filesystem::path& path) {
  return detail::check_store_file(path);
}

std::string utc_now_iso8601() {
  const auto now = std::chrono::system_clock::now();
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch());
  const std::time_t secs = static_cast<std::time_t>(ms.count() / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S", &tm);
  char buf[48];
  std::snprintf(buf, sizeof buf, "%s.%03dZ", date, static_cast<int>(ms.count() % 1000));
  return buf;
}

const char* to_string(StudyState s) noexcept {
  switch (s) {
    case StudyState::kQueued: return "queued";
    case StudyState::kRunning: return "running";
    case StudyState::kSucceeded: return "succeeded";
    case StudyState::kFailed: return "failed";
    case StudyState::kCancelled: return "cancelled";
  }
  return "unknown";
}

std::optional<StudyState> parse_study_state(std::string_view s) noexcept {
  for (const StudyState st : {StudyState::kQueued, StudyState::kRunning, StudyState::kSucceeded,
                              StudyState::kFailed, StudyState::kCancelled})
    if (s == to_string(st)) return st;
  return std::nullopt;
}

bool is_valid_run_status(std::string_view status) noexcept {
  return status == "ok" || status == "diverged" || status == "invalid";
}

Store::Store(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
Store::Store(Store&&) noexcept = default;
Store& Store::operator=(Store&&) noexcept = default;
Store::~Store() = default;

Store Store::open(const std::filesystem::path& path, Mode mode,
                  std::chrono::milliseconds busy_timeout) {
  return Store(std::make_unique<Impl>(Impl{detail::open_connection(path, mode, busy_timeout)}));
}

const std::filesystem::path& Store::path() const noexcept { return impl_->conn.path(); }

namespace detail {

bool is_json_object(const std::string& text) {
  const auto j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  return j.is_object();
}

bool is_json(const std::string& text) {
  return !nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false).is_discarded();
}

}  // namespace detail
}  // namespace stickslip::store
