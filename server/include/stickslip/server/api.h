#pragma once
// The REST API of stickslipd as pure functions Request -> Response (schemas/openapi.json).
//
//   POST /v1/studies                   202 + Location; Idempotency-Key honoured
//   GET  /v1/studies                   page_size, page_token -> next_page_token; name (contains)
//   GET  /v1/studies/{id}              state, progress {total, done, failed}, timestamps
//   GET  /v1/studies/{id}/runs         JSON pages, or CSV with Accept: text/csv
//   GET  /v1/studies/{id}/map          stick-slip map, JSON or CSV
//   POST /v1/studies/{id}:cancel
//   GET  /v1/studies/{id}/indices      Sobol / Morris indices (output=a,b; confidence=0.95)
//   GET  /v1/reports                   nightly reports (dates); GET /v1/reports/{date}/...
//   POST /v1/diagnoses                 202 + Location; manifest + CSV contents (+ options)
//   GET  /v1/diagnoses                 page_size, page_token -> next_page_token
//   GET  /v1/diagnoses/{id}            state, timestamps, and diagnosis.json once succeeded
//   GET  /v1/diagnoses/{id}/traces     the runs whose series are stored (measured, base, extended)
//   GET  /v1/diagnoses/{id}/traces/{k} run k's series: JSON (max_points, t_min, t_max) or CSV
//   POST /v1/diagnoses/{id}:cancel
//   GET  /healthz, GET /metrics (Prometheus text), GET /v1/openapi.json
//   GET  /, GET /ui/...                the web dashboard (dashboard.h): static files that call /v1
//
// Every response carries the Content-Security-Policy of dashboard.h (no inline script, nothing
// from another origin), X-Content-Type-Options: nosniff and Referrer-Policy: no-referrer.
//
// Every handler leases its own Store connection from the pool, so handlers may run on any number
// of threads at once. Bad requests are 4xx application/problem+json naming the offending field;
// a 5xx means the server or its store failed, never the request.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <mutex>
#include <unordered_map>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <functional>
#include <variant>

#include <nlohmann/json.hpp>

#include "stickslip/server/health.h"
#include "stickslip/server/http.h"
#include "stickslip/server/job_worker.h"
#include "stickslip/server/router.h"
#include "stickslip/server/store_pool.h"
#include "stickslip/studies/spec.h"

namespace stickslip::server {

struct ApiOptions {
  std::filesystem::path db = "stickslip.db";
  studies::Limits limits;                 ///< runs per study, durations, dt bounds
  std::size_t max_body_bytes = 1 << 20;   ///< larger request bodies get 413 [bytes]
  /// The same for POST /v1/diagnoses, whose body carries whole CSV files: 64 MiB holds about
  /// 3 runs x 20 s x 2 kHz many times over (one sample line is ~25 bytes) [bytes].
  std::size_t max_diagnosis_body_bytes = std::size_t{64} << 20;
  int diagnosis_threads = 0;              ///< DiagnoseOptions::threads when re-checking requests
  std::string token;                      ///< bearer token for state changes; empty: none
  std::size_t default_page_size = 50;     ///< studies per page when page_size is absent
  std::size_t default_runs_page_size = 100;
  std::size_t max_page_size = 1000;
  std::filesystem::path reports_dir;      ///< `stickslip report --out` directory; empty: none
  /// GET /v1/studies/{id} answers from a per-study cache for this long (0: off). Progress is
  /// committed in batches every 0.5 s anyway, so a poller sees nothing staler than that; 50
  /// clients polling one study then cost one store read per period instead of one per request.
  std::chrono::milliseconds study_cache_ttl{100};

  /// True if every field holds. Otherwise appends one message per broken constraint, naming the
  /// field and the value, to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// One kind of job as an HTTP resource: what the one set of create, list, get and cancel
/// handlers (api_jobs.cpp) needs to know about it. Defined for studies in api.cpp and for
/// diagnoses in api_diagnoses.cpp; a new kind of job adds one.
struct JobResource {
  std::string kind;          ///< the store's job kind, e.g. "study"
  std::string collection;    ///< "/v1/studies"
  std::string list_key;      ///< the list's member, "studies"
  std::string noun;          ///< in messages and problem types: "study" (study-not-found, ...)
  std::string title;         ///< in problem titles: "Study"
  std::string request_noun;  ///< "a study" (415: "<request_noun> must be sent as ...")
  std::size_t max_body_bytes = 0;
  std::string max_body_option;  ///< the stickslipd option that sets it, e.g. "--max-body"
  JobScheduler* scheduler = nullptr;  ///< null: jobs are only queued; cancel acts on the store
  bool name_filter = false;           ///< the list takes ?name= (a substring of the name)
  store::JobColumns detail_columns;   ///< read for the single-job form
  store::JobColumns list_columns;     ///< read for a list page
  /// The resource's JSON; detail: the single-job form (spec, result, ...), else a list entry.
  std::function<nlohmann::json(const store::JobRecord&, bool detail)> to_json;
  /// Every check the worker will make on a POST body (doc is its parsed JSON): the job to store
  /// (kind, name, request, progress total), or the 4xx problem.
  std::function<std::variant<store::NewJob, Response>(const nlohmann::json& doc,
                                                      const Request& r)>
      check;
};

class Api {
 public:
  /// Opens the store (throws studies::StoreError naming the path when it cannot) and registers
  /// the routes. scheduler (studies) and diagnoses may be null (then jobs of that kind are only
  /// queued; cancel acts on the store directly). health (may be null): /healthz reports it.
  Api(ApiOptions options, JobScheduler* scheduler = nullptr, JobScheduler* diagnoses = nullptr,
      std::shared_ptr<const Health> health = nullptr, JobScheduler* validations = nullptr);

  /// Routes and handles one request. Never throws.
  Response handle(const Request& request) const;
  /// The answer to GET /v1/studies/{id} from the study cache, when a fresh entry exists (200, or
  /// 304 for a matching If-None-Match), counted like handle(); nullopt otherwise (then call
  /// handle()). Never reads the store and never blocks beyond a short mutex, so the HTTP layer
  /// may call it on an I/O thread (HttpServer's inline handler) and skip the hand-off to the
  /// handler pool. Never throws.
  std::optional<Response> handle_cached(const Request& request) const;
  const Router& router() const noexcept { return router_; }
  const ApiOptions& options() const noexcept { return options_; }

  /// Requests answered so far, per status class (index 1..5 for 1xx..5xx) for /metrics.
  std::uint64_t responses(int status_class) const noexcept;

 private:
  // The job resources (api_jobs.cpp): one set of handlers for every kind.
  Response create_job(const Request& r, const JobResource& res) const;
  Response list_jobs(const Request& r, const JobResource& res) const;
  Response get_job(const Request& r, const JobResource& res, const std::string& id) const;
  Response cancel_job(const Request& r, const JobResource& res, const std::string& id) const;
  /// Registers the four routes of res under res.collection (get: the handler of
  /// GET {collection}/{id}, e.g. with a cache).
  void add_job_routes(const JobResource& res,
                      std::function<Response(const Request&, const std::string&)> get);
  JobResource study_resource(JobScheduler* scheduler) const;      // api.cpp
  JobResource diagnosis_resource(JobScheduler* scheduler) const;  // api_diagnoses.cpp
  JobResource validation_resource(JobScheduler* scheduler) const;  // api_validations.cpp
  void add_validation_routes();                                    // api_validations.cpp

  Response get_study(const Request& r, const std::string& id) const;
  Response get_runs(const Request& r, const std::string& id) const;
  Response get_map(const Request& r, const std::string& id) const;
  Response get_indices(const Request& r, const std::string& id) const;
  Response list_reports(const Request& r) const;
  /// A file of a report: reports_dir/date/sub/name (sub "" or "plots"); names are checked.
  Response get_report_file(const Request& r, const std::string& date, const std::string& sub,
                           const std::string& name) const;
  Response list_diagnosis_traces(const Request& r, const std::string& id) const;
  Response list_validation_traces(const Request& r, const std::string& id) const;
  Response get_validation_trace(const Request& r, const std::string& id, const std::string& run) const;
  Response get_diagnosis_trace(const Request& r, const std::string& id,
                               const std::string& run) const;
  Response healthz(const Request& r) const;
  Response metrics(const Request& r) const;
  Response openapi(const Request& r) const;
  /// A file of the dashboard (dashboard.h), "" = index.html.
  Response dashboard_file(const Request& r, const std::string& path) const;
  /// nullopt when the request may change state; else the 401/403 problem.
  std::optional<Response> check_token(const Request& r) const;

  ApiOptions options_;
  std::shared_ptr<const Health> health_;
  mutable StorePool pool_;
  JobResource studies_, diagnoses_, validations_;
  Router router_;
  mutable std::array<std::atomic<std::uint64_t>, 6> responses_{};
  struct CachedStudy {
    std::chrono::steady_clock::time_point at;
    Response response;
  };
  mutable std::mutex cache_mu_;
  mutable std::unordered_map<std::string, CachedStudy> study_cache_;
  void forget_cached(const std::string& id) const;
  /// The cached GET /v1/studies/{id} response, if younger than study_cache_ttl.
  std::optional<Response> cached_study(const Request& r, const std::string& id) const;
};

/// full itself, or 304 Not Modified (its ETag and Cache-Control, no body) when the request's
/// If-None-Match lists full's ETag (weak comparison, RFC 9110 13.1.2).
Response conditional_response(const Request& r, const Response& full);

/// The OpenAPI 3.1 document (schemas/openapi.json) embedded at build time.
std::string_view openapi_text() noexcept;

}  // namespace stickslip::server
