// Diagnosis records of the store (store.h): a diagnosis is a job of kind "diagnosis" whose
// request is {"manifest", "files", "options"} and whose result is diagnosis.json (jobs.cpp holds
// the records; this file adapts them).
#include <bit>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>

#include "records.h"

namespace stickslip::store {

using detail::fail;
using detail::Statement;

namespace {

constexpr const char* kKind = "diagnosis";
constexpr JobColumns kWithResult{.request = false, .result = true};

std::optional<DiagnosisRecord> as_diagnosis(std::optional<JobRecord> job) {
  if (!job || job->kind != kKind) return std::nullopt;
  return diagnosis_from_job(*job);
}

}  // namespace

DiagnosisRecord diagnosis_from_job(const JobRecord& job) {
  DiagnosisRecord r;
  r.id = job.id;
  r.name = job.name;
  r.request_hash = job.request_hash;
  r.state = job.state;
  r.created_at = job.created_at;
  r.started_at = job.started_at;
  r.finished_at = job.finished_at;
  r.error = job.error;
  r.result_json = job.result_json;
  r.idempotency_key = job.idempotency_key;
  return r;
}

CreatedDiagnosis Store::create_diagnosis(const NewDiagnosis& d) {
  NewJob j;
  j.id = d.id.empty() ? new_diagnosis_id() : d.id;
  if (!detail::is_json_object(d.request_json))
    fail(path(), "creating diagnosis " + j.id + ": request_json is not a JSON object");
  j.kind = kKind;
  j.name = d.name;
  j.request_json = d.request_json;
  j.request_hash = d.request_hash;
  j.idempotency_key = d.idempotency_key;
  if (d.idempotency_key) j.idempotency_hash = d.request_hash;
  auto created = create_job(j);
  if (created.job.kind != kKind)
    fail(path(), "creating diagnosis " + j.id + ": a job of another kind has this id");
  return {diagnosis_from_job(created.job), created.created};
}

std::optional<DiagnosisRecord> Store::get_diagnosis(const std::string& id) {
  return as_diagnosis(get_job(id, kWithResult));
}

std::optional<std::string> Store::get_diagnosis_request(const std::string& id) {
  auto job = get_job(id, {.request = true, .result = false});
  if (!job || job->kind != kKind) return std::nullopt;
  return job->request_json;
}

std::optional<DiagnosisRecord> Store::find_diagnosis_by_idempotency_key(const std::string& key) {
  return as_diagnosis(find_job_by_idempotency_key(kKind, key, kWithResult));
}

std::vector<DiagnosisRecord> Store::list_diagnoses(std::size_t page_size,
                                                   const std::string& after_id) {
  std::vector<DiagnosisRecord> out;
  for (const auto& job : list_jobs(kKind, page_size, after_id))
    out.push_back(diagnosis_from_job(job));
  return out;
}

void Store::set_diagnosis_state(const std::string& id, StudyState state,
                                const std::optional<std::string>& error) {
  detail::set_job_state(impl_->conn, id, kKind, state, error);
}

bool Store::requeue_diagnosis(const std::string& id) {
  const auto job = get_job(id);
  if (!job || job->kind != kKind || job->state != StudyState::kRunning) return false;
  return requeue_job(id, job->error);
}

namespace {

/// n doubles as n little-endian IEEE-754 binary64 values (as encode_column).
std::vector<unsigned char> encode_doubles(const std::vector<double>& v) {
  std::vector<unsigned char> out(v.size() * 8);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const auto bits = std::bit_cast<std::uint64_t>(v[i]);
    for (std::size_t k = 0; k < 8; ++k) out[8 * i + k] = static_cast<unsigned char>(bits >> (8 * k));
  }
  return out;
}

std::vector<double> decode_doubles(const std::vector<unsigned char>& bytes) {
  std::vector<double> out(bytes.size() / 8);
  for (std::size_t i = 0; i < out.size(); ++i) {
    std::uint64_t bits = 0;
    for (std::size_t k = 0; k < 8; ++k) bits |= std::uint64_t{bytes[8 * i + k]} << (8 * k);
    out[i] = std::bit_cast<double>(bits);
  }
  return out;
}

}  // namespace

bool Store::finish_diagnosis(const std::string& id, StudyState state,
                             const std::optional<std::string>& result_json,
                             const std::optional<std::string>& error,
                             const std::vector<DiagnosisTrace>& traces) {
  if (state != StudyState::kSucceeded && state != StudyState::kFailed)
    fail(path(), "finishing diagnosis " + id + ": the state must be succeeded or failed");
  for (std::size_t k = 0; k < traces.size(); ++k) {
    const auto& tr = traces[k];
    const std::size_t n = tr.t.size();
    if (tr.measured.size() != n || tr.base.size() != n ||
        (!tr.extended.empty() && tr.extended.size() != n))
      fail(path(), "finishing diagnosis " + id + ": trace " + std::to_string(k) + " (run '" +
                       tr.run + "') has series of different lengths (t " + std::to_string(n) +
                       ", measured " + std::to_string(tr.measured.size()) + ", base " +
                       std::to_string(tr.base.size()) + ", extended " +
                       std::to_string(tr.extended.size()) + ")");
  }
  const std::string doing = "finishing diagnosis " + id;
  // The outcome (jobs.cpp) and the traces in one transaction.
  detail::Transaction tx(impl_->conn, detail::Transaction::Kind::kWrite, doing);
  const bool finished = finish_job(id, state, result_json, error);
  if (finished && !traces.empty()) {
    detail::Statement del(impl_->conn, "DELETE FROM diagnosis_traces WHERE diagnosis_id = ?1",
                          doing);
    del.bind_text(1, id).run();
    detail::Statement ins(impl_->conn,
                          "INSERT INTO diagnosis_traces (diagnosis_id, run_index, run, n_samples, "
                          "t, measured, base, extended) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
                          doing);
    for (std::size_t k = 0; k < traces.size(); ++k) {
      const auto& tr = traces[k];
      ins.bind_text(1, id).bind_int(2, static_cast<std::int64_t>(k)).bind_text(3, tr.run);
      ins.bind_int(4, static_cast<std::int64_t>(tr.t.size()));
      ins.bind_blob(5, encode_doubles(tr.t)).bind_blob(6, encode_doubles(tr.measured));
      ins.bind_blob(7, encode_doubles(tr.base)).bind_blob(8, encode_doubles(tr.extended));
      ins.run();
    }
  }
  tx.commit(doing);
  return finished;
}

std::vector<DiagnosisTraceInfo> Store::list_diagnosis_traces(const std::string& id) {
  // The first and last time are the first and last 8 bytes of t (no need to read the series).
  Statement st(impl_->conn,
               "SELECT run_index, run, n_samples, substr(t, 1, 8), substr(t, -8, 8), "
               "length(extended) > 0 FROM diagnosis_traces WHERE diagnosis_id = ?1 "
               "ORDER BY run_index",
               "listing the traces of diagnosis " + id);
  st.bind_text(1, id);
  std::vector<DiagnosisTraceInfo> out;
  while (st.step()) {
    DiagnosisTraceInfo info;
    info.run_index = st.int64(0);
    info.run = st.text(1);
    info.samples = st.int64(2);
    const auto first = decode_doubles(st.blob(3)), last = decode_doubles(st.blob(4));
    const double nan = std::numeric_limits<double>::quiet_NaN();
    info.t_first = info.samples > 0 && first.size() == 1 ? first[0] : nan;
    info.t_last = info.samples > 0 && last.size() == 1 ? last[0] : nan;
    info.has_extended = st.int64(5) != 0;
    out.push_back(std::move(info));
  }
  return out;
}

std::optional<DiagnosisTrace> Store::get_diagnosis_trace(const std::string& id,
                                                         std::int64_t run_index) {
  const std::string doing =
      "reading trace " + std::to_string(run_index) + " of diagnosis " + id;
  Statement st(impl_->conn,
               "SELECT run, n_samples, t, measured, base, extended FROM diagnosis_traces "
               "WHERE diagnosis_id = ?1 AND run_index = ?2",
               doing);
  st.bind_text(1, id).bind_int(2, run_index);
  if (!st.step()) return std::nullopt;
  DiagnosisTrace tr;
  tr.run = st.text(0);
  const auto n = static_cast<std::size_t>(st.int64(1));
  tr.t = decode_doubles(st.blob(2));
  tr.measured = decode_doubles(st.blob(3));
  tr.base = decode_doubles(st.blob(4));
  tr.extended = decode_doubles(st.blob(5));
  if (tr.t.size() != n || tr.measured.size() != n || tr.base.size() != n ||
      (!tr.extended.empty() && tr.extended.size() != n))
    fail(path(), "corrupt " + doing + ": column length mismatch");
  return tr;
}

}  // namespace stickslip::store
