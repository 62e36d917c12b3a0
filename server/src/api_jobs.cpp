// The job-resource handlers of the API (api.h), one set for every kind of job: create (POST
// /v1/studies, /v1/diagnoses), list, get and cancel. What differs per kind (how a request is
// checked and how a job is shown) is in its JobResource (api_studies.cpp, api_diagnoses.cpp).
#include <nlohmann/json.hpp>

#include "api_util.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/server/api.h"

namespace stickslip::server {
namespace {

using nlohmann::json;
using store::JobRecord;
using store::StoreError;

Response unknown_job(const JobResource& res, const std::string& id, const std::string& instance) {
  return detail::unknown_job(res.noun, res.title, id, instance);
}

Response idempotency_conflict(const JobResource& res, const std::string& key,
                              const std::string& id) {
  return problem(422, "idempotency-key-reused", "Idempotency-Key reused",
                 "Idempotency-Key \"" + key + "\" was already used for " + res.noun + " " + id +
                     " with a different request body; use a new key for a new " + res.noun,
                 {FieldError::header("Idempotency-Key", "already used with another body")},
                 res.collection);
}

Response job_response(int status, const JobResource& res, const JobRecord& rec) {
  Response r = json_response(status, res.to_json(rec, true));
  r.set_header("Location", res.collection + "/" + rec.id);
  return r;
}

Response replay(const JobResource& res, const JobRecord& rec) {
  Response r = job_response(202, res, rec);
  r.set_header("Idempotent-Replayed", "true");
  return r;
}

/// The checks every POST body gets before its kind looks at it: media type, size, the
/// Idempotency-Key header, nesting depth and JSON syntax. nullopt: the parsed document.
std::optional<Response> check_body(const Request& r, const JobResource& res,
                                   std::optional<json>* doc) {
  const auto content_type = r.header("Content-Type");
  if (!content_type || !detail::is_json_content_type(*content_type)) {
    return problem(415, "unsupported-media-type", "Unsupported media type",
                   res.request_noun + " must be sent as application/json, got " +
                       (content_type ? "\"" + *content_type + "\""
                                     : std::string("no Content-Type")),
                   {FieldError::header("Content-Type", "expected application/json")},
                   res.collection);
  }
  if (r.body.size() > res.max_body_bytes) {
    return problem(413, "body-too-large", "Request body too large",
                   "the body has " + std::to_string(r.body.size()) + " bytes; the limit for " +
                       res.collection + " is " + std::to_string(res.max_body_bytes) +
                       " (stickslipd " + res.max_body_option + ")",
                   {}, res.collection);
  }
  if (auto bad = detail::check_idempotency_key(r, res.collection)) return *bad;
  if (common::json_nesting_depth(r.body) > common::kMaxJsonDepth) {
    const std::string levels = std::to_string(common::kMaxJsonDepth) + " levels";
    return problem(400, "malformed-json", "Malformed JSON",
                   "the request body nests arrays and objects more than " + levels + " deep",
                   {FieldError::body("", "nesting deeper than " + levels)}, res.collection);
  }
  std::vector<common::SpecError> errors;
  *doc = common::parse_json(r.body, &errors);
  if (*doc) return std::nullopt;
  return problem(400, "malformed-json", "Malformed JSON",
                 "the request body is not valid JSON: " + common::to_string(errors),
                 detail::body_errors(errors), res.collection);
}

}  // namespace

Response Api::create_job(const Request& r, const JobResource& res) const {
  if (auto denied = check_token(r)) return *denied;
  std::optional<json> doc;
  if (auto bad = check_body(r, res, &doc)) return *bad;
  const auto key = r.header("Idempotency-Key");
  // The request's identity for Idempotency-Key: the hash of its canonical JSON (sorted keys,
  // compact), so a replay that differs only in whitespace or key order is still a replay.
  const std::string request_hash = store::param_hash(doc->dump());
  try {
    auto store = pool_.acquire();
    if (key) {
      if (auto prior = store->find_job_by_idempotency_key(res.kind, *key, res.detail_columns)) {
        if (prior->idempotency_hash != request_hash)
          return idempotency_conflict(res, *key, prior->id);
        return replay(res, *prior);
      }
    }
    // Every check the worker will make, so that a bad request is a 422 now, never a failed job.
    auto checked = res.check(*doc, r);
    if (auto* p = std::get_if<Response>(&checked)) return std::move(*p);
    auto& job = std::get<store::NewJob>(checked);
    job.idempotency_key = key;
    if (key) job.idempotency_hash = request_hash;
    const auto created = store->create_job(job);
    if (!created.created) {  // the same key was stored concurrently
      if (created.job.idempotency_hash != request_hash)
        return idempotency_conflict(res, *key, created.job.id);
      return replay(res, created.job);
    }
    if (res.scheduler != nullptr) res.scheduler->notify();
    return job_response(202, res, created.job);
  } catch (const StoreError& e) {
    return detail::store_failure(e, res.collection);
  }
}

Response Api::list_jobs(const Request& r, const JobResource& res) const {
  Response error;
  const auto page = detail::id_page_params(r, options_.default_page_size,
                                           options_.max_page_size, &error);
  if (!page) return error;
  std::string name;
  if (res.name_filter) {
    const auto q = r.query();
    if (const auto it = q.find("name"); it != q.end()) name = it->second;
    if (name.size() > 200)
      return problem(400, "invalid-parameter", "Invalid query parameter",
                     "name must be at most 200 characters, got " + std::to_string(name.size()),
                     {FieldError::query("name", "at most 200 characters")}, res.collection);
  }
  try {
    auto store = pool_.acquire();
    if (!page->after.empty()) {
      // A page token is the id of the last job of the previous page: anything else is a 400.
      const auto last = store->get_job(page->after);
      if (!last || last->kind != res.kind) return detail::bad_page_token(r);
    }
    auto rows = store->list_jobs(res.kind, page->size + 1, page->after, res.list_columns, name);
    const json next = detail::take_id_page(rows, page->size);
    json out = {{res.list_key, json::array()}};
    for (const auto& rec : rows) out[res.list_key].push_back(res.to_json(rec, false));
    out["next_page_token"] = next;
    return json_response(200, out);
  } catch (const StoreError& e) {
    return detail::store_failure(e, res.collection);
  }
}

Response Api::get_job(const Request& r, const JobResource& res, const std::string& id) const {
  if (!detail::is_valid_id(id)) return unknown_job(res, id, r.path());
  try {
    auto store = pool_.acquire();
    const auto rec = store->get_job(id, res.detail_columns);
    if (!rec || rec->kind != res.kind) return unknown_job(res, id, r.path());
    return json_response(200, res.to_json(*rec, true));
  } catch (const StoreError& e) {
    return detail::store_failure(e, r.path());
  }
}

Response Api::cancel_job(const Request& r, const JobResource& res, const std::string& id) const {
  if (auto denied = check_token(r)) return *denied;
  if (!detail::is_valid_id(id)) return unknown_job(res, id, r.path());
  try {
    auto store = pool_.acquire();
    const CancelOutcome outcome = res.scheduler != nullptr
                                      ? res.scheduler->cancel(*store, id)
                                      : cancel_unclaimed(*store, res.kind, id);
    forget_cached(id);  // the canceller's next GET shows the new state
    if (outcome == CancelOutcome::kNotFound) return unknown_job(res, id, r.path());
    const auto rec = store->get_job(id, res.detail_columns);
    if (!rec || rec->kind != res.kind) return unknown_job(res, id, r.path());
    if (outcome == CancelOutcome::kAlreadyFinished && rec->state != store::StudyState::kCancelled) {
      return problem(409, res.noun + "-finished", res.title + " already finished",
                     res.noun + " " + id + " is " + store::to_string(rec->state) +
                         " and can no longer be cancelled",
                     {}, r.path());
    }
    // 202: a kDeferred job's runner stops starting work and ends it cancelled shortly.
    Response resp = job_response(outcome == CancelOutcome::kRequested ? 202 : 200, res, *rec);
    return resp;
  } catch (const StoreError& e) {
    return detail::store_failure(e, r.path());
  }
}

}  // namespace stickslip::server
