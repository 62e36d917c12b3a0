// The diagnosis resources of the API (see api.h): POST /v1/diagnoses with a manifest and the
// contents of its CSV files (schemas/diagnosis_request.schema.json), GET one or a page of them,
// and cancel. The diagnosis itself runs in the DiagnosisWorker, never on a handler thread.
#include <nlohmann/json.hpp>

#include "api_util.h"
#include "stickslip/server/api.h"
#include "stickslip/diagnosis/diagnosis_request.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/store/store.h"

namespace stickslip::server {
namespace {

using nlohmann::json;
using store::DiagnosisRecord;
using store::StoreError;

const std::string kCollection = "/v1/diagnoses";

json opt_text(const std::optional<std::string>& v) { return v ? json(*v) : json(nullptr); }

/// The resource: id, name, state, timestamps, error, links; the diagnosis.json document under
/// "result" once it succeeded (when with_result).
json diagnosis_json(const DiagnosisRecord& rec, bool with_result) {
  const std::string self = kCollection + "/" + rec.id;
  json j = {{"id", rec.id},
            {"name", rec.name},
            {"state", store::to_string(rec.state)},
            {"created_at", rec.created_at},
            {"started_at", opt_text(rec.started_at)},
            {"finished_at", opt_text(rec.finished_at)},
            {"error", opt_text(rec.error)},
            {"links", {{"self", self}, {"cancel", self + ":cancel"}}}};
  if (with_result) {
    json result = nullptr;
    if (rec.result_json) {
      // Stored by the worker from to_json(); a damaged one is left out, not a 500.
      result = json::parse(*rec.result_json, nullptr, false);
      if (result.is_discarded()) result = nullptr;
    }
    j["result"] = std::move(result);
  }
  return j;
}

Response diagnosis_response(int status, const DiagnosisRecord& rec) {
  Response r = json_response(status, diagnosis_json(rec, true));
  r.set_header("Location", kCollection + "/" + rec.id);
  return r;
}

Response unknown_diagnosis(const std::string& id, const std::string& instance) {
  return problem(404, "diagnosis-not-found", "Diagnosis not found",
                 "no diagnosis with id \"" + id + "\"", {}, instance);
}

Response idempotency_conflict(const std::string& key, const std::string& id) {
  return problem(422, "idempotency-key-reused", "Idempotency-Key reused",
                 "Idempotency-Key \"" + key + "\" was already used for diagnosis " + id +
                     " with a different request body; use a new key for a new diagnosis",
                 {FieldError::header("Idempotency-Key", "already used with another body")},
                 kCollection);
}

Response replay(const DiagnosisRecord& rec) {
  Response r = diagnosis_response(202, rec);
  r.set_header("Idempotent-Replayed", "true");
  return r;
}

std::vector<FieldError> body_errors(const std::vector<common::SpecError>& errors) {
  std::vector<FieldError> out;
  for (const auto& e : errors) out.push_back(FieldError::body(e.pointer, e.message));
  return out;
}

}  // namespace

Response Api::create_diagnosis(const Request& r) const {
  if (auto denied = check_token(r)) return *denied;
  const auto content_type = r.header("Content-Type");
  if (!content_type || !detail::is_json_content_type(*content_type)) {
    return problem(415, "unsupported-media-type", "Unsupported media type",
                   "a diagnosis request must be sent as application/json, got " +
                       (content_type ? "\"" + *content_type + "\"" : std::string("no Content-Type")),
                   {FieldError::header("Content-Type", "expected application/json")}, kCollection);
  }
  if (r.body.size() > options_.max_diagnosis_body_bytes) {
    return problem(413, "body-too-large", "Request body too large",
                   "the body has " + std::to_string(r.body.size()) + " bytes; the limit for " +
                       "diagnoses is " + std::to_string(options_.max_diagnosis_body_bytes) +
                       " (stickslipd --max-diagnosis-body)",
                   {}, kCollection);
  }
  if (auto bad = detail::check_idempotency_key(r, kCollection)) return *bad;
  const auto key = r.header("Idempotency-Key");
  if (common::json_nesting_depth(r.body) > common::kMaxJsonDepth) {
    return problem(400, "malformed-json", "Malformed JSON",
                   "the request body nests arrays and objects more than " +
                       std::to_string(common::kMaxJsonDepth) + " levels deep",
                   {FieldError::body("", "nesting deeper than " +
                                             std::to_string(common::kMaxJsonDepth) + " levels")},
                   kCollection);
  }
  std::vector<common::SpecError> json_errors;
  const auto doc = common::parse_json(r.body, &json_errors);
  if (!doc) {
    return problem(400, "malformed-json", "Malformed JSON",
                   "the request body is not valid JSON: " + common::to_string(json_errors),
                   body_errors(json_errors), kCollection);
  }
  // The canonical request (sorted keys, compact) is what is stored and hashed, so a replay that
  // differs only in whitespace or key order is still a replay.
  std::string canonical = doc->dump();
  const std::string request_hash = store::param_hash(canonical);
  try {
    auto store = pool_.acquire();
    if (key) {
      if (auto prior = store->find_diagnosis_by_idempotency_key(*key)) {
        if (prior->request_hash != request_hash) return idempotency_conflict(*key, prior->id);
        return replay(*prior);
      }
    }
    // Every check the worker will make (schema, options, CSV contents), so that a bad request
    // is a 422 now, never a failed diagnosis later.
    const auto parsed = diagnosis::parse_diagnosis_request(*doc, options_.diagnosis_threads);
    if (!parsed.ok()) {
      return problem(422, "invalid-diagnosis", "Invalid diagnosis request",
                     std::to_string(parsed.errors.size()) +
                         " problem(s) in the diagnosis request: " +
                         common::to_string(parsed.errors),
                     body_errors(parsed.errors), kCollection);
    }
    store::NewDiagnosis nd;
    nd.name = parsed.request->data.name;
    nd.request_json = std::move(canonical);
    nd.request_hash = request_hash;
    nd.idempotency_key = key;
    const auto created = store->create_diagnosis(nd);
    if (!created.created) {  // the same key was stored concurrently
      if (created.diagnosis.request_hash != request_hash)
        return idempotency_conflict(*key, created.diagnosis.id);
      return replay(created.diagnosis);
    }
    if (diagnoses_ != nullptr) diagnoses_->notify_diagnosis();
    return diagnosis_response(202, created.diagnosis);
  } catch (const StoreError& e) {
    return detail::store_failure(e, kCollection);
  }
}

Response Api::list_diagnoses(const Request& r) const {
  Response error;
  const auto page = detail::id_page_params(r, options_.default_page_size,
                                           options_.max_page_size, &error);
  if (!page) return error;
  try {
    auto store = pool_.acquire();
    auto rows = store->list_diagnoses(page->size + 1, page->after);
    const json next = detail::take_id_page(rows, page->size);
    json out = {{"diagnoses", json::array()}};
    for (const auto& rec : rows) out["diagnoses"].push_back(diagnosis_json(rec, false));
    out["next_page_token"] = next;
    return json_response(200, out);
  } catch (const StoreError& e) {
    return detail::store_failure(e, kCollection);
  }
}

Response Api::get_diagnosis(const Request& r, const std::string& id) const {
  if (!detail::is_valid_id(id)) return unknown_diagnosis(id, r.path());
  try {
    auto store = pool_.acquire();
    const auto rec = store->get_diagnosis(id);
    if (!rec) return unknown_diagnosis(id, r.path());
    return json_response(200, diagnosis_json(*rec, true));
  } catch (const StoreError& e) {
    return detail::store_failure(e, r.path());
  }
}

Response Api::cancel_diagnosis(const Request& r, const std::string& id) const {
  if (auto denied = check_token(r)) return *denied;
  if (!detail::is_valid_id(id)) return unknown_diagnosis(id, r.path());
  try {
    auto store = pool_.acquire();
    const CancelOutcome outcome = diagnoses_ != nullptr
                                      ? diagnoses_->cancel_diagnosis(*store, id)
                                      : cancel_diagnosis_unclaimed(*store, id);
    if (outcome == CancelOutcome::kNotFound) return unknown_diagnosis(id, r.path());
    const auto rec = store->get_diagnosis(id);
    if (!rec) return unknown_diagnosis(id, r.path());
    if (outcome == CancelOutcome::kAlreadyFinished &&
        rec->state != store::StudyState::kCancelled) {
      return problem(409, "diagnosis-finished", "Diagnosis already finished",
                     "diagnosis " + id + " is " + store::to_string(rec->state) +
                         " and can no longer be cancelled",
                     {}, r.path());
    }
    return diagnosis_response(200, *rec);
  } catch (const StoreError& e) {
    return detail::store_failure(e, r.path());
  }
}

}  // namespace stickslip::server
