// The diagnosis resource of the API (see api.h): what the job handlers (api_jobs.cpp) need to
// know about diagnoses (POST /v1/diagnoses carries a manifest and the contents of its CSV files,
// schemas/diagnosis_request.schema.json), and their stored traces. The diagnosis itself runs in
// the DiagnosisWorker, never on a handler thread.
#include <algorithm>
#include <charconv>
#include <cmath>

#include <nlohmann/json.hpp>

#include "api_util.h"
#include "stickslip/server/api.h"
#include "stickslip/diagnosis/diagnose.h"
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
            {"links", {{"self", self}, {"cancel", self + ":cancel"}, {"traces", self + "/traces"}}}};
  if (with_result) {
    json result = nullptr;
    if (rec.result_json) {
      // Stored by the worker from to_json(); a damaged one is left out, not a 500.
      result = json::parse(*rec.result_json, nullptr, false);
      if (result.is_discarded()) result = nullptr;
    }
    // The evidence view of the named cause (diagnosis::evidence_view), for readers that mark it.
    if (result.is_object() && result.contains("cause") && result["cause"].is_string())
      j["cause_view"] = std::string(diagnosis::evidence_view(result["cause"].get<std::string>()));
    else
      j["cause_view"] = nullptr;
    j["result"] = std::move(result);
  }
  return j;
}

Response unknown_diagnosis(const std::string& id, const std::string& instance) {
  return detail::unknown_job("diagnosis", "Diagnosis", id, instance);
}

}  // namespace

JobResource Api::diagnosis_resource(JobScheduler* scheduler) const {
  JobResource res;
  res.kind = "diagnosis";
  res.collection = kCollection;
  res.list_key = "diagnoses";
  res.noun = "diagnosis";
  res.title = "Diagnosis";
  res.request_noun = "a diagnosis request";
  res.max_body_bytes = options_.max_diagnosis_body_bytes;
  res.max_body_option = "--max-diagnosis-body";
  res.scheduler = scheduler;
  res.detail_columns = {.request = false, .result = true};
  res.list_columns = {};
  res.to_json = [scheduler](const store::JobRecord& job, bool detail) {
    json j = diagnosis_json(store::diagnosis_from_job(job), detail);
    // The running diagnosis' phase, models or candidates, evaluations and time left.
    if (detail) {  // while it runs (the board is cleared just after the outcome is stored)
      const auto p = scheduler && job.state == store::StudyState::kRunning ? scheduler->progress(job.id)
                                                                          : std::nullopt;
      j["progress"] = p ? *p : json(nullptr);
    }
    return j;
  };
  res.check = [this](const json& doc, const Request&) -> std::variant<store::NewJob, Response> {
    // Every check the worker will make (schema, options, CSV contents).
    const auto parsed = diagnosis::parse_diagnosis_request(doc, options_.diagnosis_threads);
    if (!parsed.ok()) {
      return problem(422, "invalid-diagnosis", "Invalid diagnosis request",
                     std::to_string(parsed.errors.size()) +
                         " problem(s) in the diagnosis request: " +
                         common::to_string(parsed.errors),
                     detail::body_errors(parsed.errors), kCollection);
    }
    // The canonical request (sorted keys, compact) is what is stored and hashed.
    store::NewJob job;
    job.kind = "diagnosis";
    job.name = parsed.request->data.name;
    job.request_json = doc.dump();
    job.request_hash = store::param_hash(job.request_json);
    return job;
  };
  return res;
}

namespace {

constexpr std::size_t kDefaultTracePoints = 2000;
constexpr std::size_t kMaxTracePoints = 200000;

/// A finite number from a query parameter, or the 400 problem in *error.
std::optional<double> number_param(const Request& r, const std::string& name, Response* error) {
  const auto q = r.query();
  const auto it = q.find(name);
  if (it == q.end()) return std::nullopt;
  double v = 0;
  const auto& s = it->second;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || !std::isfinite(v)) {
    *error = problem(400, "invalid-parameter", "Invalid query parameter",
                     name + " must be a finite number [s], got \"" + s + "\"",
                     {FieldError::query(name, "not a finite number: \"" + s + "\"")}, r.path());
  }
  return v;
}

/// Indices of [begin, end) to show at most max_points samples: all of them when they fit, else
/// per bucket of equal sample count the samples of the measured force's minimum and maximum,
/// in time order (the sticks and slips stay visible, which a fixed stride can skip).
std::vector<std::size_t> decimate(const std::vector<double>& measured, std::size_t begin,
                                  std::size_t end, std::size_t max_points) {
  std::vector<std::size_t> out;
  const std::size_t n = end - begin;
  if (n <= max_points) {
    for (std::size_t i = begin; i < end; ++i) out.push_back(i);
    return out;
  }
  const std::size_t buckets = std::max<std::size_t>(1, max_points / 2);
  for (std::size_t b = 0; b < buckets; ++b) {
    const std::size_t lo = begin + b * n / buckets, hi = begin + (b + 1) * n / buckets;
    if (lo >= hi) continue;
    std::size_t imin = lo, imax = lo;
    for (std::size_t i = lo; i < hi; ++i) {
      if (measured[i] < measured[imin]) imin = i;
      if (measured[i] > measured[imax]) imax = i;
    }
    out.push_back(std::min(imin, imax));
    if (imin != imax) out.push_back(std::max(imin, imax));
  }
  return out;
}

/// Every sample of [begin, stop) (no decimation), with both residuals, as the .dat files of
/// `stickslip diagnose --out`.
Response trace_csv(const store::DiagnosisTrace& tr, std::size_t begin, std::size_t stop) {
  const bool has_ext = !tr.extended.empty();
  std::string csv = "t,measured,base,extended,residual_base,residual_extended\n";
  for (std::size_t i = begin; i < stop; ++i) {
    const double ext = has_ext ? tr.extended[i] : std::nan("");
    csv += detail::csv_number(tr.t[i]) + "," + detail::csv_number(tr.measured[i]) + "," +
           detail::csv_number(tr.base[i]) + "," + detail::csv_number(ext) + "," +
           detail::csv_number(tr.measured[i] - tr.base[i]) + "," +
           detail::csv_number(tr.measured[i] - ext) + "\n";
  }
  return text_response(200, "text/csv; charset=utf-8", std::move(csv));
}

/// The samples of [begin, stop), decimated to at most max_points, as the JSON resource.
Response trace_json(const std::string& id, std::int64_t index, const store::DiagnosisTrace& tr,
                    std::size_t begin, std::size_t stop, std::size_t max_points) {
  const bool has_ext = !tr.extended.empty();
  const auto keep = decimate(tr.measured, begin, stop, max_points);
  json t = json::array(), measured = json::array(), base = json::array();
  json extended = has_ext ? json::array() : json(nullptr);
  for (const std::size_t i : keep) {
    t.push_back(detail::number_or_null(tr.t[i]));
    measured.push_back(detail::number_or_null(tr.measured[i]));
    base.push_back(detail::number_or_null(tr.base[i]));
    if (has_ext) extended.push_back(detail::number_or_null(tr.extended[i]));
  }
  return json_response(200, {{"diagnosis_id", id},
                             {"index", index},
                             {"run", tr.run},
                             {"samples", stop - begin},
                             {"total_samples", tr.t.size()},
                             {"returned", keep.size()},
                             {"decimated", keep.size() < stop - begin},
                             {"t", std::move(t)},
                             {"measured", std::move(measured)},
                             {"base", std::move(base)},
                             {"extended", std::move(extended)}});
}

}  // namespace

Response Api::list_diagnosis_traces(const Request& r, const std::string& id) const {
  if (!detail::is_valid_id(id)) return unknown_diagnosis(id, r.path());
  try {
    auto store = pool_.acquire();
    const auto rec = store->get_diagnosis(id);
    if (!rec) return unknown_diagnosis(id, r.path());
    json runs = json::array();
    for (const auto& info : store->list_diagnosis_traces(id)) {
      const std::string self =
          kCollection + "/" + id + "/traces/" + std::to_string(info.run_index);
      runs.push_back({{"index", info.run_index},
                      {"run", info.run},
                      {"samples", info.samples},
                      {"t_first", detail::number_or_null(info.t_first)},
                      {"t_last", detail::number_or_null(info.t_last)},
                      {"extended", info.has_extended},
                      {"links", {{"self", self}, {"csv", self + "?format=csv"}}}});
    }
    return json_response(200, {{"diagnosis_id", id},
                               {"state", store::to_string(rec->state)},
                               {"runs", std::move(runs)}});
  } catch (const StoreError& e) {
    return detail::store_failure(e, r.path());
  }
}

Response Api::get_diagnosis_trace(const Request& r, const std::string& id,
                                  const std::string& run) const {
  const auto format = detail::negotiate(r, true);
  if (!format) return detail::not_acceptable(r, true);
  if (!detail::is_valid_id(id)) return unknown_diagnosis(id, r.path());
  std::int64_t index = -1;
  {
    const auto [end, ec] = std::from_chars(run.data(), run.data() + run.size(), index);
    if (ec != std::errc{} || end != run.data() + run.size() || index < 0)
      return problem(404, "trace-not-found", "Trace not found",
                     "traces are numbered from 0 in manifest order (GET " + kCollection + "/" + id +
                         "/traces lists them), got \"" + run + "\"",
                     {}, r.path());
  }
  Response error;
  const auto max_points = detail::page_size_param_named(r, "max_points", kDefaultTracePoints,
                                                        kMaxTracePoints, &error);
  if (!max_points) return error;
  if (*max_points < 2)
    return problem(400, "invalid-parameter", "Invalid query parameter",
                   "max_points must be at least 2, got " + std::to_string(*max_points),
                   {FieldError::query("max_points", "must be an integer from 2 to " +
                                                        std::to_string(kMaxTracePoints))},
                   r.path());
  error.status = 0;
  const auto t_min = number_param(r, "t_min", &error);
  if (error.status != 0) return error;
  const auto t_max = number_param(r, "t_max", &error);
  if (error.status != 0) return error;
  if (t_min && t_max && *t_min > *t_max)
    return problem(400, "invalid-parameter", "Invalid query parameter",
                   "t_min must not exceed t_max",
                   {FieldError::query("t_min", "greater than t_max")}, r.path());
  try {
    auto store = pool_.acquire();
    if (!store->get_diagnosis(id)) return unknown_diagnosis(id, r.path());
    const auto tr = store->get_diagnosis_trace(id, index);
    if (!tr)
      return problem(404, "trace-not-found", "Trace not found",
                     "diagnosis " + id + " has no stored trace " + run +
                         " (traces are stored when a diagnosis succeeds; GET " + kCollection +
                         "/" + id + "/traces lists them)",
                     {}, r.path());
    // The window [t_min, t_max] (inclusive) as a range of sample indices; t is increasing.
    const std::size_t begin =
        t_min ? static_cast<std::size_t>(std::lower_bound(tr->t.begin(), tr->t.end(), *t_min) -
                                         tr->t.begin())
              : 0;
    const std::size_t end =
        t_max ? static_cast<std::size_t>(std::upper_bound(tr->t.begin(), tr->t.end(), *t_max) -
                                         tr->t.begin())
              : tr->t.size();
    const std::size_t stop = std::max(begin, end);
    if (*format == detail::Format::kCsv) return trace_csv(*tr, begin, stop);
    return trace_json(id, index, *tr, begin, stop, *max_points);
  } catch (const StoreError& e) {
    return detail::store_failure(e, r.path());
  }
}

}  // namespace stickslip::server
