// Study records of the store (store.h): a study is a job of kind "study" whose request is its
// canonical spec, whose request_hash is the spec's hash and whose progress counts its runs
// (jobs.cpp holds the records; this file adapts them).
#include <string>
#include <utility>

#include "records.h"

namespace stickslip::store {

using detail::fail;

namespace {

constexpr const char* kKind = "study";
constexpr JobColumns kWithSpec{.request = true, .result = false};

std::optional<StudyRecord> as_study(std::optional<JobRecord> job) {
  if (!job || job->kind != kKind) return std::nullopt;
  return study_from_job(*job);
}

}  // namespace

StudyRecord study_from_job(const JobRecord& job) {
  StudyRecord r;
  r.id = job.id;
  r.name = job.name;
  r.spec_json = job.request_json.value_or("");
  r.spec_hash = job.request_hash;
  r.state = job.state;
  r.total_runs = job.progress.total;
  r.created_at = job.created_at;
  r.started_at = job.started_at;
  r.finished_at = job.finished_at;
  r.error = job.error;
  r.idempotency_key = job.idempotency_key;
  r.request_hash = job.idempotency_hash;
  return r;
}

RunCounts run_counts_of(const JobRecord& job) {
  return {job.progress.total, job.progress.done, job.progress.done - job.progress.failed,
          job.progress.failed};
}

CreatedStudy Store::create_study(const NewStudy& s) {
  NewJob j;
  j.id = s.id.empty() ? new_study_id() : s.id;
  j.kind = kKind;
  j.name = s.name;
  j.request_json = s.spec_json;
  j.request_hash = s.spec_hash;
  j.progress_total = s.total_runs;
  j.idempotency_key = s.idempotency_key;
  j.idempotency_hash = s.request_hash;
  if (s.total_runs < 0) fail(path(), "creating study " + j.id + ": negative total_runs");
  auto created = create_job(j);
  if (created.job.kind != kKind)
    fail(path(), "creating study " + j.id + ": a job of another kind has this id");
  return {study_from_job(created.job), created.created};
}

std::optional<StudyRecord> Store::get_study(const std::string& id) {
  return as_study(get_job(id, kWithSpec));
}

std::optional<StudyRecord> Store::find_by_idempotency_key(const std::string& key) {
  return as_study(find_job_by_idempotency_key(kKind, key, kWithSpec));
}

std::optional<StudyRecord> Store::find_newest_by_name(const std::string& name) {
  return as_study(impl_->job_where(kWithSpec, "WHERE kind = ?1 AND name = ?2 ORDER BY id DESC "
                                              "LIMIT 1",
                                   {kKind, name}));
}

std::optional<StudyRecord> Store::find_resumable(const std::string& name,
                                                const std::string& spec_hash) {
  return as_study(impl_->job_where(kWithSpec,
                                   "WHERE kind = ?1 AND name = ?2 AND request_hash = ?3 AND "
                                   "state <> 'cancelled' ORDER BY id DESC LIMIT 1",
                                   {kKind, name, spec_hash}));
}

std::vector<StudyRecord> Store::list_studies(std::size_t page_size, const std::string& after_id,
                                            const std::string& name_contains) {
  std::vector<StudyRecord> out;
  for (const auto& job : list_jobs(kKind, page_size, after_id, kWithSpec, name_contains))
    out.push_back(study_from_job(job));
  return out;
}

void Store::extend_study(const std::string& id, std::int64_t total_runs) {
  detail::Statement st(impl_->conn,
                       "UPDATE jobs SET progress_total = ?1 "
                       "WHERE id = ?2 AND kind = 'study' AND progress_total <= ?1",
                       "extending study " + id);
  st.bind_int(1, total_runs).bind_text(2, id).run();
  if (impl_->conn.changes() > 0) return;
  const auto study = get_study(id);
  if (!study) fail(path(), "extending study " + id + ": no such study");
  fail(path(), "extending study " + id + ": " + std::to_string(total_runs) +
                   " runs is fewer than the " + std::to_string(study->total_runs) + " it has");
}

void Store::set_study_state(const std::string& id, StudyState state,
                            const std::optional<std::string>& error) {
  detail::set_job_state(impl_->conn, id, kKind, state, error);
}

}  // namespace stickslip::store
