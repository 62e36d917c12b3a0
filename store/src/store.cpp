// The SQLite store (store.h; schema in schema.cpp, documented in docs/store.md): ids, hashes and
// states, opening a Store, and what its study and diagnosis records share. The records
// themselves: studies.cpp, diagnoses.cpp, runs.cpp (read side) and run_writer.cpp (write side).
#include "stickslip/store/store.h"

#include <cinttypes>
#include <cstdio>
#include <ctime>
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

namespace {
std::string new_id(const char* prefix) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  std::random_device rd;
  const std::uint32_t rnd = rd();
  char buf[32];
  const std::uint64_t ms48 = static_cast<std::uint64_t>(ms) & 0xffffffffffffULL;
  std::snprintf(buf, sizeof buf, "%s-%012" PRIx64 "%08" PRIx32, prefix, ms48, rnd);
  return buf;
}
}  // namespace

std::string new_study_id() { return new_id("st"); }
std::string new_diagnosis_id() { return new_id("dg"); }

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

// One state-transition rule for both kinds of job (studies, diagnoses): started_at is set on
// the first 'running', finished_at on a terminal state and cleared otherwise. table is one of
// the two fixed table names; kind names the job in errors.
void set_job_state(const Connection& conn, const char* table, const char* kind,
                   const std::string& id, StudyState state,
                   const std::optional<std::string>& error) {
  const std::string sql =
      std::string("UPDATE ") + table +
      " SET state = ?1, error = ?2, "
      "started_at = CASE WHEN ?1 = 'running' THEN COALESCE(started_at, ?3) "
      "                  ELSE started_at END, "
      "finished_at = CASE WHEN ?1 IN ('succeeded', 'failed', 'cancelled') THEN ?3 "
      "                   ELSE NULL END "
      "WHERE id = ?4";
  const std::string doing = std::string("setting the state of ") + kind + " " + id;
  Statement st(conn, sql.c_str(), doing);
  st.bind_text(1, to_string(state)).bind_opt_text(2, error).bind_text(3, utc_now_iso8601());
  st.bind_text(4, id).run();
  if (conn.changes() == 0) fail(conn.path(), doing + ": no such " + kind);
}

}  // namespace detail
}  // namespace stickslip::store
