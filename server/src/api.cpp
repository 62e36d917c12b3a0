// Routes, authentication and the study-resource handlers of the API (see api.h).
#include "stickslip/server/api.h"

#include <charconv>
#include <cstdint>
#include <cstdio>

#include "api_util.h"
#include "stickslip/server/dashboard.h"
#include "stickslip/common/text.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/diagnosis/diagnosis_request.h"
#include "stickslip/store/store.h"
#include "stickslip/studies/export.h"

namespace stickslip::server {

using detail::is_valid_id;
using detail::store_failure;
using nlohmann::json;
using store::StoreError;
using store::StudyRecord;

bool ApiOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  if (db.empty()) fail("db: empty path");
  if (max_body_bytes < 64)
    fail("max_body_bytes: must be >= 64, got " + std::to_string(max_body_bytes));
  if (max_diagnosis_body_bytes < 64)
    fail("max_diagnosis_body_bytes: must be >= 64, got " +
         std::to_string(max_diagnosis_body_bytes));
  if (diagnosis_threads < 0)
    fail("diagnosis_threads: must be >= 0, got " + std::to_string(diagnosis_threads));
  if (limits.max_runs < 1)
    fail("limits.max_runs: must be >= 1, got " + std::to_string(limits.max_runs));
  if (max_page_size < 1) fail("max_page_size: must be >= 1, got " + std::to_string(max_page_size));
  if (default_page_size < 1 || default_page_size > max_page_size)
    fail("default_page_size: must be in [1, max_page_size], got " +
         std::to_string(default_page_size));
  if (default_runs_page_size < 1 || default_runs_page_size > max_page_size)
    fail("default_runs_page_size: must be in [1, max_page_size], got " +
         std::to_string(default_runs_page_size));
  // The token is a secret: the message names the offending character's position, not its value.
  for (std::size_t i = 0; i < token.size(); ++i)
    if (token[i] <= ' ' || token[i] > '~') {
      fail("token: only visible ASCII characters are allowed, got another at character " +
           std::to_string(i + 1));
      break;
    }
  return ok;
}

CancelOutcome cancel_unclaimed(store::Store& store, const std::string& id) {
  const auto rec = store.get_study(id);
  if (!rec) return CancelOutcome::kNotFound;
  if (rec->state != store::StudyState::kQueued && rec->state != store::StudyState::kRunning)
    return CancelOutcome::kAlreadyFinished;
  store.set_study_state(id, store::StudyState::kCancelled);
  return CancelOutcome::kCancelled;
}

namespace {

/// Constant-time comparison of two tokens (no early exit on the first differing byte).
bool same_token(std::string_view a, std::string_view b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const std::size_t n = std::max(a.size(), b.size());
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned char>(x ^ y);
  }
  return diff == 0;
}


/// The study as `stickslip study show --json` prints it (studies/export.h), plus links.
json study_json(const StudyRecord& rec, const store::RunCounts& counts, bool with_spec) {
  const std::string self = "/v1/studies/" + rec.id;
  json j = studies::study_to_json(rec, counts);
  j["links"] = {{"self", self}, {"runs", self + "/runs"}, {"map", self + "/map"},
                {"cancel", self + ":cancel"}};
  if (with_spec) {
    // The stored spec is the canonical JSON this server (or the runner) wrote: the plain parser
    // suffices (no duplicate-key checks needed); a damaged one is left out, not a 500.
    json spec = json::parse(rec.spec_json, nullptr, false);
    if (!spec.is_discarded()) j["spec"] = std::move(spec);
  }
  return j;
}

/// A strong entity tag of a body: its 64-bit FNV-1a hash and its length, quoted. Two bodies with
/// the same tag are, in practice, the same bytes; the tag of an unchanged study is the same in
/// every process (a few lines here because the standard hashes promise no stable value).
std::string strong_etag(std::string_view body) {
  std::uint64_t h = 14695981039346656037ull;
  for (const char c : body) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ull;
  }
  char buf[48];
  std::snprintf(buf, sizeof buf, "\"%016llx-%zx\"", static_cast<unsigned long long>(h),
                body.size());
  return buf;
}

/// Whether an If-None-Match value lists etag (RFC 9110 13.1.2: weak comparison, so W/"x"
/// matches "x"; "*" matches any current representation).
bool none_match_lists(std::string_view value, std::string_view etag) {
  while (!value.empty()) {
    const auto comma = value.find(',');
    std::string_view tag = value.substr(0, comma);
    value = comma == std::string_view::npos ? std::string_view{} : value.substr(comma + 1);
    while (!tag.empty() && (tag.front() == ' ' || tag.front() == '\t')) tag.remove_prefix(1);
    while (!tag.empty() && (tag.back() == ' ' || tag.back() == '\t')) tag.remove_suffix(1);
    if (tag == "*") return true;
    if (tag.starts_with("W/")) tag.remove_prefix(2);
    if (tag == etag) return true;
  }
  return false;
}

}  // namespace

/// full itself, or 304 Not Modified (ETag and Cache-Control, no body) when the request's
/// If-None-Match lists full's ETag.
Response conditional_response(const Request& r, const Response& full) {
  const auto etag = full.header("ETag");
  const auto inm = r.header("If-None-Match");
  if (!etag || !inm || !none_match_lists(*inm, *etag)) return full;
  Response nm;
  nm.status = 304;
  nm.set_header("ETag", *etag);
  if (const auto cc = full.header("Cache-Control")) nm.set_header("Cache-Control", *cc);
  return nm;
}

Api::Api(ApiOptions options, JobScheduler* scheduler, JobScheduler* diagnoses,
         std::shared_ptr<const Health> health, JobScheduler* validations)
    : options_(std::move(options)),
      health_(std::move(health)),
      pool_(options_.db) {
  if (std::vector<std::string> errors; !options_.IsValid(&errors))
    throw std::invalid_argument("ApiOptions: " + common::join(errors, "; "));
  auto id_of = [](const PathParams& p) { return p.at("id"); };
  studies_ = study_resource(scheduler);
  diagnoses_ = diagnosis_resource(diagnoses);
  validations_ = validation_resource(validations);
  add_job_routes(studies_, [this](const Request& r, const std::string& id) {
    return get_study(r, id);
  });
  router_.add("GET", "/v1/studies/{id}/runs",
              [this, id_of](const Request& r, const PathParams& p) { return get_runs(r, id_of(p)); });
  router_.add("GET", "/v1/studies/{id}/map",
              [this, id_of](const Request& r, const PathParams& p) { return get_map(r, id_of(p)); });
  router_.add("GET", "/v1/studies/{id}/indices",
              [this, id_of](const Request& r, const PathParams& p) {
                return get_indices(r, id_of(p));
              });
  router_.add("GET", "/v1/reports",
              [this](const Request& r, const PathParams&) { return list_reports(r); });
  router_.add("GET", "/v1/reports/{date}/{file}",
              [this](const Request& r, const PathParams& p) {
                return get_report_file(r, p.at("date"), "", p.at("file"));
              });
  router_.add("GET", "/v1/reports/{date}/plots/{file}",
              [this](const Request& r, const PathParams& p) {
                return get_report_file(r, p.at("date"), "plots", p.at("file"));
              });
  add_job_routes(diagnoses_, [this](const Request& r, const std::string& id) {
    return get_job(r, diagnoses_, id);
  });
  router_.add("GET", "/v1/diagnoses/{id}/traces",
              [this, id_of](const Request& r, const PathParams& p) {
                return list_diagnosis_traces(r, id_of(p));
              });
  router_.add("GET", "/v1/diagnoses/{id}/traces/{run}",
              [this, id_of](const Request& r, const PathParams& p) {
                return get_diagnosis_trace(r, id_of(p), p.at("run"));
              });
  add_validation_routes();
  // The dashboard: index.html at / and its files at /ui/<path> (up to three segments deep).
  router_.add("GET", "/", [this](const Request& r, const PathParams&) {
    return dashboard_file(r, "index.html");
  });
  router_.add("GET", "/ui/{file}", [this](const Request& r, const PathParams& p) {
    return dashboard_file(r, p.at("file"));
  });
  router_.add("GET", "/ui/{dir}/{file}", [this](const Request& r, const PathParams& p) {
    return dashboard_file(r, p.at("dir") + "/" + p.at("file"));
  });
  router_.add("GET", "/ui/{dir}/{sub}/{file}", [this](const Request& r, const PathParams& p) {
    return dashboard_file(r, p.at("dir") + "/" + p.at("sub") + "/" + p.at("file"));
  });
  router_.add("GET", "/healthz", [this](const Request& r, const PathParams&) { return healthz(r); });
  router_.add("GET", "/metrics", [this](const Request& r, const PathParams&) { return metrics(r); });
  router_.add("GET", "/v1/openapi.json",
              [this](const Request& r, const PathParams&) { return openapi(r); });
  // The study schema, which openapi.json references as "study.schema.json" (a sibling both in
  // schemas/ and under /v1/).
  router_.add("GET", "/v1/study.schema.json", [](const Request&, const PathParams&) {
    Response resp =
        text_response(200, "application/schema+json", std::string(studies::study_schema_text()));
    resp.set_header("Cache-Control", "public, max-age=3600");
    return resp;
  });
  router_.add("GET", "/v1/diagnosis_request.schema.json", [](const Request&, const PathParams&) {
    Response resp = text_response(200, "application/schema+json",
                                  std::string(diagnosis::diagnosis_request_schema_text()));
    resp.set_header("Cache-Control", "public, max-age=3600");
    return resp;
  });
  router_.add("GET", "/v1/diagnosis.schema.json", [](const Request&, const PathParams&) {
    Response resp = text_response(200, "application/schema+json",
                                  std::string(diagnosis::diagnosis_schema_text()));
    resp.set_header("Cache-Control", "public, max-age=3600");
    return resp;
  });
}

namespace {

/// The headers every response carries unless its handler set its own (dashboard.h).
void add_security_headers(Response& r) {
  if (!r.header("Content-Security-Policy"))
    r.set_header("Content-Security-Policy", std::string(kContentSecurityPolicy));
  r.set_header("X-Content-Type-Options", "nosniff");
  r.set_header("Referrer-Policy", "no-referrer");
}

}  // namespace

JobResource Api::study_resource(JobScheduler* scheduler) const {
  JobResource res;
  res.kind = "study";
  res.collection = "/v1/studies";
  res.list_key = "studies";
  res.noun = "study";
  res.title = "Study";
  res.request_noun = "a study";
  res.max_body_bytes = options_.max_body_bytes;
  res.max_body_option = "--max-body";
  res.scheduler = scheduler;
  res.name_filter = true;
  res.detail_columns = res.list_columns = {.request = true, .result = false};
  res.to_json = [](const store::JobRecord& job, bool detail) {
    return study_json(store::study_from_job(job), store::run_counts_of(job), detail);
  };
  res.check = [this](const json&, const Request& r) -> std::variant<store::NewJob, Response> {
    auto parsed = studies::parse_study(r.body, options_.limits);
    if (!parsed.ok()) {
      return problem(422, "invalid-study", "Invalid study",
                     std::to_string(parsed.errors.size()) + " problem(s) in the study: " +
                         common::to_string(parsed.errors),
                     detail::body_errors(parsed.errors), "/v1/studies");
    }
    // Stored like `stickslip study run` stores it (runner.h create_or_find_study): the
    // canonical spec, with every default filled in, and its hash.
    const auto& spec = *parsed.spec;
    store::NewJob job;
    job.kind = "study";
    job.name = spec.name();
    job.request_json = spec.canonical_json();
    job.request_hash = store::param_hash(job.request_json);
    job.progress_total = static_cast<std::int64_t>(spec.run_count());
    return job;
  };
  return res;
}

void Api::add_job_routes(const JobResource& res,
                         std::function<Response(const Request&, const std::string&)> get) {
  router_.add("POST", res.collection,
              [this, &res](const Request& r, const PathParams&) { return create_job(r, res); });
  router_.add("GET", res.collection,
              [this, &res](const Request& r, const PathParams&) { return list_jobs(r, res); });
  router_.add("GET", res.collection + "/{id}",
              [get](const Request& r, const PathParams& p) { return get(r, p.at("id")); });
  router_.add("POST", res.collection + "/{id}:cancel",
              [this, &res](const Request& r, const PathParams& p) {
                return cancel_job(r, res, p.at("id"));
              });
}

Response Api::handle(const Request& request) const {
  Response r = router_.route(request);
  if (!r.header("Cache-Control")) r.set_header("Cache-Control", "no-store");
  add_security_headers(r);
  const int cls = r.status / 100;
  if (cls >= 1 && cls <= 5) responses_[static_cast<std::size_t>(cls)].fetch_add(1);
  return r;
}

std::uint64_t Api::responses(int status_class) const noexcept {
  if (status_class < 1 || status_class > 5) return 0;
  return responses_[static_cast<std::size_t>(status_class)].load();
}

std::optional<Response> Api::check_token(const Request& r) const {
  if (options_.token.empty()) return std::nullopt;
  const auto auth = r.header("Authorization");
  if (!auth) {
    Response p = problem(401, "unauthorized", "Unauthorized",
                         "this endpoint changes state and needs \"Authorization: Bearer <token>\"",
                         {FieldError::header("Authorization", "missing")}, r.path());
    p.set_header("WWW-Authenticate", "Bearer realm=\"stickslipd\"");
    return p;
  }
  constexpr std::string_view kBearer = "Bearer ";
  const bool bearer = auth->size() >= kBearer.size() &&
                      iequals(std::string_view(*auth).substr(0, kBearer.size()), kBearer);
  if (!bearer) {
    Response p = problem(401, "unauthorized", "Unauthorized",
                         "the Authorization header must use the Bearer scheme",
                         {FieldError::header("Authorization", "not a Bearer credential")},
                         r.path());
    p.set_header("WWW-Authenticate", "Bearer realm=\"stickslipd\", error=\"invalid_request\"");
    return p;
  }
  if (!same_token(std::string_view(*auth).substr(kBearer.size()), options_.token)) {
    return problem(403, "forbidden", "Forbidden", "the bearer token is not valid",
                   {FieldError::header("Authorization", "wrong token")}, r.path());
  }
  return std::nullopt;
}

std::optional<Response> Api::cached_study(const Request& r, const std::string& id) const {
  if (options_.study_cache_ttl.count() <= 0) return std::nullopt;
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard lock(cache_mu_);
  const auto it = study_cache_.find(id);
  if (it == study_cache_.end() || now - it->second.at >= options_.study_cache_ttl)
    return std::nullopt;
  return conditional_response(r, it->second.response);
}

std::optional<Response> Api::handle_cached(const Request& request) const {
  // Only GET /v1/studies/{id} (exactly; not /runs, /map, :cancel), as the router would match it.
  constexpr std::string_view kPrefix = "/v1/studies/";
  if (request.method != "GET" || options_.study_cache_ttl.count() <= 0) return std::nullopt;
  const std::string path = request.path();
  if (!path.starts_with(kPrefix)) return std::nullopt;
  const std::string id = path.substr(kPrefix.size());
  if (!is_valid_id(id)) return std::nullopt;  // ids have no '/' or ':'; the router answers
  auto resp = cached_study(request, id);
  if (resp) {
    add_security_headers(*resp);
    responses_[static_cast<std::size_t>(resp->status / 100)].fetch_add(1);
  }
  return resp;
}

Response Api::get_study(const Request& r, const std::string& id) const {
  if (auto hit = cached_study(r, id)) return std::move(*hit);
  // Taken before the store is read, so a cached entry is never older than the TTL says.
  const auto now = std::chrono::steady_clock::now();
  Response resp = get_job(r, studies_, id);
  if (resp.status != 200) return resp;
  resp.set_header("ETag", strong_etag(resp.body));
  // May be stored, but must be revalidated (If-None-Match) before each use.
  resp.set_header("Cache-Control", "no-cache");
  if (options_.study_cache_ttl.count() > 0) {
    std::lock_guard lock(cache_mu_);
    if (study_cache_.size() >= 1024) study_cache_.clear();  // bounded; entries are cheap
    study_cache_[id] = {now, resp};
  }
  return conditional_response(r, resp);
}

void Api::forget_cached(const std::string& id) const {
  std::lock_guard lock(cache_mu_);
  study_cache_.erase(id);
}

Response Api::healthz(const Request& r) const {
  if (health_) {
    if (const auto problem_text = health_->problem()) {
      // A worker is paused by a store fault: the server still answers reads, but runs nothing.
      Response p = problem(503, "degraded", "Degraded", *problem_text, {}, r.path());
      auto body = json::parse(p.body);
      body["health"] = "degraded";
      p.body = body.dump();
      p.set_header("Retry-After", "1");
      return p;
    }
  }
  try {
    auto store = pool_.acquire();
    store->list_jobs("study", 1);
    return json_response(200, {{"status", "ok"}});
  } catch (const StoreError& e) {
    return problem(503, "unhealthy", "Unhealthy", std::string("store: ") + e.what(), {}, r.path());
  }
}

Response Api::dashboard_file(const Request& r, const std::string& path) const {
  const auto asset = find_web_asset(path);
  if (!asset)
    return problem(404, "not-found", "Not found", "the dashboard has no file \"" + path + "\"", {},
                   r.path());
  Response resp = text_response(200, std::string(asset->content_type), std::string(asset->body));
  resp.set_header("ETag", std::string(asset->etag));
  // Vendored files have their version in their path; the dashboard's own are revalidated (a
  // 304 without a body) on every load, so a new server's pages are used at once.
  resp.set_header("Cache-Control", asset->immutable ? "public, max-age=31536000, immutable"
                                                    : "no-cache");
  return conditional_response(r, resp);
}

Response Api::openapi(const Request&) const {
  Response resp = text_response(200, "application/json", std::string(openapi_text()));
  resp.set_header("Cache-Control", "public, max-age=3600");
  return resp;
}

}  // namespace stickslip::server
