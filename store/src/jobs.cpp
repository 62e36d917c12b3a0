// Job records of the store (store.h, "jobs"): one row per job of any kind in the jobs table,
// created with its request, claimed through the jobs_pending index, finished with a result or
// an error. Studies and diagnoses are kinds of job (studies.cpp, diagnoses.cpp adapt them).
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "records.h"

namespace stickslip::store {

using detail::Connection;
using detail::fail;
using detail::Statement;
using detail::to_limit;
using detail::Transaction;

namespace {

constexpr const char* kJobColumns =
    "id, kind, name, state, request_hash, progress_total, progress_done, progress_failed, "
    "created_at, started_at, finished_at, error, idempotency_key, idempotency_hash";
constexpr int kJobColumnCount = 14;

/// "SELECT <columns>[, request_json][, result_json] FROM jobs <where_order>".
std::string select_jobs(JobColumns cols, std::string_view where_order) {
  std::string sql = std::string("SELECT ") + kJobColumns;
  sql += cols.request ? ", request_json" : ", NULL";
  sql += cols.result ? ", result_json" : ", NULL";
  return sql + " FROM jobs " + std::string(where_order);
}

JobRecord read_job(const Statement& st, const std::filesystem::path& path) {
  JobRecord r;
  r.id = st.text(0);
  r.kind = st.text(1);
  r.name = st.text(2);
  const auto state = parse_study_state(st.text(3));
  if (!state) fail(path, r.kind + " " + r.id + " has an unknown state '" + st.text(3) + "'");
  r.state = *state;
  r.request_hash = st.text(4);
  r.progress = {st.int64(5), st.int64(6), st.int64(7)};
  r.created_at = st.text(8);
  r.started_at = st.opt_text(9);
  r.finished_at = st.opt_text(10);
  r.error = st.opt_text(11);
  r.idempotency_key = st.opt_text(12);
  r.idempotency_hash = st.opt_text(13);
  r.request_json = st.opt_text(kJobColumnCount);
  r.result_json = st.opt_text(kJobColumnCount + 1);
  return r;
}

/// A job's id prefix: "st" for studies, "dg" for diagnoses, else the kind's first two letters.
std::string id_prefix(const std::string& kind) {
  if (kind == "study") return "st";
  if (kind == "diagnosis") return "dg";
  return kind.substr(0, 2);
}

}  // namespace

std::optional<JobRecord> Store::Impl::job_where(JobColumns cols, std::string_view where,
                                                std::initializer_list<std::string_view> values) {
  Statement st(conn, select_jobs(cols, where).c_str(), "reading a job");
  int i = 1;
  for (const auto v : values) st.bind_text(i++, v);
  if (!st.step()) return std::nullopt;
  return read_job(st, conn.path());
}

CreatedJob Store::create_job(const NewJob& j) {
  const std::string id = j.id.empty() ? new_job_id(id_prefix(j.kind)) : j.id;
  const std::string doing = "creating " + j.kind + " " + id;
  if (j.kind.empty()) fail(path(), doing + ": empty kind");
  if (!detail::is_json(j.request_json)) fail(path(), doing + ": the request is not JSON");
  if (j.progress_total < 0) fail(path(), doing + ": negative progress total");
  const JobColumns all{true, true};
  Transaction tx(impl_->conn, Transaction::Kind::kWrite, doing);
  if (j.idempotency_key) {
    if (auto existing = impl_->job_where(all, "WHERE kind = ?1 AND idempotency_key = ?2",
                                         {j.kind, *j.idempotency_key})) {
      tx.commit("idempotency lookup");
      return {std::move(*existing), false};
    }
  }
  if (impl_->job_where({}, "WHERE id = ?1", {id}))
    fail(path(), doing + ": a job with this id already exists");
  Statement st(impl_->conn,
               "INSERT INTO jobs (id, kind, name, state, request_json, request_hash, "
               "idempotency_key, idempotency_hash, progress_total, created_at) "
               "VALUES (?1, ?2, ?3, 'queued', ?4, ?5, ?6, ?7, ?8, ?9)",
               doing);
  st.bind_text(1, id).bind_text(2, j.kind).bind_text(3, j.name).bind_text(4, j.request_json);
  st.bind_text(5, j.request_hash.empty() ? param_hash(j.request_json) : j.request_hash);
  st.bind_opt_text(6, j.idempotency_key).bind_opt_text(7, j.idempotency_hash);
  st.bind_int(8, j.progress_total).bind_text(9, utc_now_iso8601()).run();
  auto stored = impl_->job_where(all, "WHERE id = ?1", {id});
  tx.commit(doing);
  return {std::move(stored.value()), true};
}

std::optional<JobRecord> Store::get_job(const std::string& id, JobColumns cols) {
  return impl_->job_where(cols, "WHERE id = ?1", {id});
}

std::optional<JobRecord> Store::find_job_by_idempotency_key(const std::string& kind,
                                                            const std::string& key,
                                                            JobColumns cols) {
  return impl_->job_where(cols, "WHERE kind = ?1 AND idempotency_key = ?2", {kind, key});
}

std::vector<JobRecord> Store::list_jobs(const std::string& kind, std::size_t page_size,
                                        const std::string& after_id, JobColumns cols,
                                        const std::string& name_contains) {
  // instr() on lower() of both: a plain substring test (LIKE would give '%' and '_' a meaning).
  Statement st(impl_->conn,
               select_jobs(cols, "WHERE kind = ?1 AND id > ?2 AND "
                                 "(?4 = '' OR instr(lower(name), lower(?4)) > 0) "
                                 "ORDER BY id LIMIT ?3")
                   .c_str(),
               "listing jobs of kind " + kind);
  st.bind_text(1, kind).bind_text(2, after_id).bind_int(3, to_limit(page_size));
  st.bind_text(4, name_contains);
  std::vector<JobRecord> out;
  while (st.step()) out.push_back(read_job(st, path()));
  return out;
}

std::vector<std::string> Store::pending_jobs(const std::string& kind, std::size_t limit) {
  // The claim query: one range of the partial index jobs_pending, already in id order (its
  // WHERE repeats the index's condition word for word, and INDEXED BY makes SQLite use it or
  // fail to prepare, never fall back to scanning every job).
  Statement st(impl_->conn,
               "SELECT id FROM jobs INDEXED BY jobs_pending "
               "WHERE kind = ?1 AND state IN ('queued', 'running') "
               "ORDER BY id LIMIT ?2",
               "reading the queue of " + kind + " jobs");
  st.bind_text(1, kind).bind_int(2, to_limit(limit));
  std::vector<std::string> ids;
  while (st.step()) ids.push_back(st.text(0));
  return ids;
}

bool Store::claim_job(const std::string& id) {
  Statement st(impl_->conn,
               "UPDATE jobs SET state = 'running', error = NULL, finished_at = NULL, "
               "started_at = COALESCE(started_at, ?2) "
               "WHERE id = ?1 AND state IN ('queued', 'running')",
               "claiming job " + id);
  st.bind_text(1, id).bind_text(2, utc_now_iso8601()).run();
  return impl_->conn.changes() > 0;
}

void Store::set_job_state(const std::string& id, StudyState state,
                          const std::optional<std::string>& error) {
  detail::set_job_state(impl_->conn, id, nullptr, state, error);
}

bool Store::finish_job(const std::string& id, StudyState state,
                       const std::optional<std::string>& result_json,
                       const std::optional<std::string>& error) {
  const std::string doing = "finishing job " + id;
  if (state != StudyState::kSucceeded && state != StudyState::kFailed &&
      state != StudyState::kCancelled)
    fail(path(), doing + ": the state must be succeeded, failed or cancelled");
  if (result_json && !detail::is_json_object(*result_json))
    fail(path(), doing + ": the result is not a JSON object");
  Statement st(impl_->conn,
               "UPDATE jobs SET state = ?1, result_json = ?2, error = ?3, finished_at = ?4 "
               "WHERE id = ?5 AND state IN ('queued', 'running')",
               doing);
  st.bind_text(1, to_string(state)).bind_opt_text(2, result_json).bind_opt_text(3, error);
  st.bind_text(4, utc_now_iso8601()).bind_text(5, id).run();
  return impl_->conn.changes() > 0;
}

bool Store::requeue_job(const std::string& id, const std::optional<std::string>& error) {
  Statement st(impl_->conn,
               "UPDATE jobs SET state = 'queued', error = ?2, finished_at = NULL "
               "WHERE id = ?1 AND state IN ('queued', 'running')",
               "re-queueing job " + id);
  st.bind_text(1, id).bind_opt_text(2, error).run();
  return impl_->conn.changes() > 0;
}

namespace detail {

void set_job_state(const Connection& conn, const std::string& id, const char* kind,
                   StudyState state, const std::optional<std::string>& error) {
  // started_at is set on the first 'running', finished_at on a terminal state and cleared
  // otherwise. kind (when given) must match: set_study_state never touches a diagnosis.
  const std::string sql = std::string(
                              "UPDATE jobs SET state = ?1, error = ?2, "
                              "started_at = CASE WHEN ?1 = 'running' THEN COALESCE(started_at, ?3) "
                              "                  ELSE started_at END, "
                              "finished_at = CASE WHEN ?1 IN ('succeeded', 'failed', 'cancelled') "
                              "                   THEN ?3 ELSE NULL END "
                              "WHERE id = ?4") +
                          (kind != nullptr ? " AND kind = ?5" : "");
  const std::string noun = kind != nullptr ? kind : "job";
  const std::string doing = "setting the state of " + noun + " " + id;
  Statement st(conn, sql.c_str(), doing);
  st.bind_text(1, to_string(state)).bind_opt_text(2, error).bind_text(3, utc_now_iso8601());
  st.bind_text(4, id);
  if (kind != nullptr) st.bind_text(5, kind);
  st.run();
  if (conn.changes() == 0) fail(conn.path(), doing + ": no such " + noun);
}

}  // namespace detail
}  // namespace stickslip::store
