// Study records of the store (store.h).
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "records.h"

namespace stickslip::store {

using detail::fail;
using detail::Statement;
using detail::to_limit;
using detail::Transaction;

namespace {

constexpr const char* kStudyColumns =
    "id, name, spec_json, spec_hash, state, total_runs, created_at, started_at, finished_at, "
    "error, idempotency_key, request_hash";

std::string select_studies(const char* where_order) {
  return std::string("SELECT ") + kStudyColumns + " FROM studies " + where_order;
}

StudyRecord read_study(const Statement& st, const std::filesystem::path& path) {
  StudyRecord r;
  r.id = st.text(0);
  r.name = st.text(1);
  r.spec_json = st.text(2);
  r.spec_hash = st.text(3);
  const auto state = parse_study_state(st.text(4));
  if (!state) fail(path, "study " + r.id + " has an unknown state '" + st.text(4) + "'");
  r.state = *state;
  r.total_runs = st.int64(5);
  r.created_at = st.text(6);
  r.started_at = st.opt_text(7);
  r.finished_at = st.opt_text(8);
  r.error = st.opt_text(9);
  r.idempotency_key = st.opt_text(10);
  r.request_hash = st.opt_text(11);
  return r;
}

bool is_json(const std::string& text) {
  return !nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false).is_discarded();
}

}  // namespace

std::optional<StudyRecord> Store::Impl::study_where(const char* where, const std::string& value,
                                                    const std::string* value2) {
  Statement st(conn, select_studies(where).c_str(), "reading a study");
  st.bind_text(1, value);
  if (value2 != nullptr) st.bind_text(2, *value2);
  if (!st.step()) return std::nullopt;
  return read_study(st, conn.path());
}

void Store::Impl::insert_study(const NewStudy& s, const std::string& id) {
  Statement st(conn,
               "INSERT INTO studies (id, name, spec_json, spec_hash, state, total_runs, "
               "created_at, idempotency_key, request_hash) "
               "VALUES (?1, ?2, ?3, ?4, 'queued', ?5, ?6, ?7, ?8)",
               "inserting study " + id);
  st.bind_text(1, id).bind_text(2, s.name).bind_text(3, s.spec_json).bind_text(4, s.spec_hash);
  st.bind_int(5, s.total_runs).bind_text(6, utc_now_iso8601());
  st.bind_opt_text(7, s.idempotency_key).bind_opt_text(8, s.request_hash);
  st.run();
}

CreatedStudy Store::create_study(const NewStudy& s) {
  const std::string id = s.id.empty() ? new_study_id() : s.id;
  if (!is_json(s.spec_json)) fail(path(), "creating study " + id + ": spec_json is not JSON");
  if (s.total_runs < 0) fail(path(), "creating study " + id + ": negative total_runs");
  Transaction tx(impl_->conn, Transaction::Kind::kWrite, "creating study " + id);
  if (s.idempotency_key) {
    if (auto existing = impl_->study_where("WHERE idempotency_key = ?1", *s.idempotency_key)) {
      tx.commit("idempotency lookup");
      return {std::move(*existing), false};
    }
  }
  if (impl_->study_where("WHERE id = ?1", id))
    fail(path(), "creating study " + id + ": a study with this id already exists");
  impl_->insert_study(s, id);
  auto stored = impl_->study_where("WHERE id = ?1", id);
  tx.commit("study " + id);
  return {std::move(stored.value()), true};
}

std::optional<StudyRecord> Store::get_study(const std::string& id) {
  return impl_->study_where("WHERE id = ?1", id);
}

std::optional<StudyRecord> Store::find_by_idempotency_key(const std::string& key) {
  return impl_->study_where("WHERE idempotency_key = ?1", key);
}

std::optional<StudyRecord> Store::find_newest_by_name(const std::string& name) {
  return impl_->study_where("WHERE name = ?1 ORDER BY id DESC LIMIT 1", name);
}

std::optional<StudyRecord> Store::find_resumable(const std::string& name,
                                                const std::string& spec_hash) {
  return impl_->study_where(
      "WHERE name = ?1 AND spec_hash = ?2 AND state <> 'cancelled' ORDER BY id DESC LIMIT 1", name,
      &spec_hash);
}

std::vector<StudyRecord> Store::list_studies(std::size_t page_size, const std::string& after_id,
                                            const std::string& name_contains) {
  // instr() on lower() of both: a plain substring test (LIKE would give '%' and '_' a meaning).
  Statement st(impl_->conn,
               select_studies("WHERE id > ?1 AND (?3 = '' OR instr(lower(name), lower(?3)) > 0) "
                              "ORDER BY id LIMIT ?2")
                   .c_str(),
               "listing studies");
  st.bind_text(1, after_id).bind_int(2, to_limit(page_size)).bind_text(3, name_contains);
  std::vector<StudyRecord> out;
  while (st.step()) out.push_back(read_study(st, path()));
  return out;
}

void Store::set_study_state(const std::string& id, StudyState state,
                            const std::optional<std::string>& error) {
  detail::set_job_state(impl_->conn, "studies", "study", id, state, error);
}

}  // namespace stickslip::store
