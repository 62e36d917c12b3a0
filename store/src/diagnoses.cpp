// Diagnosis records of the store (store.h).
#include <bit>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>

#include "records.h"

namespace stickslip::store {

using detail::Connection;
using detail::fail;
using detail::is_json_object;
using detail::Statement;
using detail::to_limit;
using detail::Transaction;

namespace {

constexpr const char* kDiagnosisColumns =
    "id, name, request_hash, state, created_at, started_at, finished_at, error, idempotency_key";

DiagnosisRecord read_diagnosis(const Statement& st, const std::filesystem::path& path) {
  DiagnosisRecord r;
  r.id = st.text(0);
  r.name = st.text(1);
  r.request_hash = st.text(2);
  const auto state = parse_study_state(st.text(3));
  if (!state) fail(path, "diagnosis " + r.id + " has an unknown state '" + st.text(3) + "'");
  r.state = *state;
  r.created_at = st.text(4);
  r.started_at = st.opt_text(5);
  r.finished_at = st.opt_text(6);
  r.error = st.opt_text(7);
  r.idempotency_key = st.opt_text(8);
  return r;
}

std::optional<DiagnosisRecord> diagnosis_where(const Connection& conn, const char* where,
                                               const std::string& value, bool with_result) {
  const std::string sql = std::string("SELECT ") + kDiagnosisColumns +
                          (with_result ? ", result_json" : "") + " FROM diagnoses " + where;
  Statement st(conn, sql.c_str(), "reading a diagnosis");
  st.bind_text(1, value);
  if (!st.step()) return std::nullopt;
  DiagnosisRecord r = read_diagnosis(st, conn.path());
  if (with_result) r.result_json = st.opt_text(9);
  return r;
}

}  // namespace

CreatedDiagnosis Store::create_diagnosis(const NewDiagnosis& d) {
  const std::string id = d.id.empty() ? new_diagnosis_id() : d.id;
  if (!is_json_object(d.request_json))
    fail(path(), "creating diagnosis " + id + ": request_json is not a JSON object");
  const auto& conn = impl_->conn;
  Transaction tx(conn, Transaction::Kind::kWrite, "creating diagnosis " + id);
  if (d.idempotency_key) {
    if (auto existing = diagnosis_where(conn, "WHERE idempotency_key = ?1", *d.idempotency_key,
                                        true)) {
      tx.commit("idempotency lookup");
      return {std::move(*existing), false};
    }
  }
  if (diagnosis_where(conn, "WHERE id = ?1", id, false))
    fail(path(), "creating diagnosis " + id + ": a diagnosis with this id already exists");
  Statement st(conn,
               "INSERT INTO diagnoses (id, name, request_json, request_hash, state, created_at, "
               "idempotency_key) VALUES (?1, ?2, ?3, ?4, 'queued', ?5, ?6)",
               "inserting diagnosis " + id);
  st.bind_text(1, id).bind_text(2, d.name).bind_text(3, d.request_json);
  st.bind_text(4, d.request_hash).bind_text(5, utc_now_iso8601());
  st.bind_opt_text(6, d.idempotency_key).run();
  auto stored = diagnosis_where(conn, "WHERE id = ?1", id, true);
  tx.commit("diagnosis " + id);
  return {std::move(stored.value()), true};
}

std::optional<DiagnosisRecord> Store::get_diagnosis(const std::string& id) {
  return diagnosis_where(impl_->conn, "WHERE id = ?1", id, true);
}

std::optional<std::string> Store::get_diagnosis_request(const std::string& id) {
  Statement st(impl_->conn, "SELECT request_json FROM diagnoses WHERE id = ?1",
               "reading the request of diagnosis " + id);
  st.bind_text(1, id);
  if (!st.step()) return std::nullopt;
  return st.text(0);
}

std::optional<DiagnosisRecord> Store::find_diagnosis_by_idempotency_key(const std::string& key) {
  return diagnosis_where(impl_->conn, "WHERE idempotency_key = ?1", key, true);
}

std::vector<DiagnosisRecord> Store::list_diagnoses(std::size_t page_size,
                                                   const std::string& after_id) {
  const std::string sql = std::string("SELECT ") + kDiagnosisColumns +
                          " FROM diagnoses WHERE id > ?1 ORDER BY id LIMIT ?2";
  Statement st(impl_->conn, sql.c_str(), "listing diagnoses");
  st.bind_text(1, after_id).bind_int(2, to_limit(page_size));
  std::vector<DiagnosisRecord> out;
  while (st.step()) out.push_back(read_diagnosis(st, path()));
  return out;
}

void Store::set_diagnosis_state(const std::string& id, StudyState state,
                                const std::optional<std::string>& error) {
  detail::set_job_state(impl_->conn, "diagnoses", "diagnosis", id, state, error);
}

bool Store::requeue_diagnosis(const std::string& id) {
  Statement st(impl_->conn,
               "UPDATE diagnoses SET state = 'queued' WHERE id = ?1 AND state = 'running'",
               "re-queueing diagnosis " + id);
  st.bind_text(1, id).run();
  return impl_->conn.changes() > 0;
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
  if (result_json && !is_json_object(*result_json))
    fail(path(), "finishing diagnosis " + id + ": result_json is not a JSON object");
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
  Transaction tx(impl_->conn, Transaction::Kind::kWrite, doing);
  Statement st(impl_->conn,
               "UPDATE diagnoses SET state = ?1, result_json = ?2, error = ?3, finished_at = ?4 "
               "WHERE id = ?5 AND state IN ('queued', 'running')",
               doing);
  st.bind_text(1, to_string(state)).bind_opt_text(2, result_json).bind_opt_text(3, error);
  st.bind_text(4, utc_now_iso8601()).bind_text(5, id).run();
  const bool finished = impl_->conn.changes() > 0;
  if (finished && !traces.empty()) {
    Statement del(impl_->conn, "DELETE FROM diagnosis_traces WHERE diagnosis_id = ?1", doing);
    del.bind_text(1, id).run();
    Statement ins(impl_->conn,
                  "INSERT INTO diagnosis_traces (diagnosis_id, run_index, run, n_samples, t, "
                  "measured, base, extended) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
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
