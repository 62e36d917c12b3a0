// The validation resource of the API (see api.h): POST /v1/validations (schemas/validation_
// request.schema.json: a diagnosis document or the id of a succeeded diagnosis, and a measured
// dataset), GET /v1/validations[/{id}] with the validation.json document under "result" and the
// running validation's progress, and each run's series at every measured sample
// (GET /v1/validations/{id}/traces[/{i}], JSON or CSV t,Fd_measured,Fd_base,Fd_extended). The
// validation itself runs in the ValidationWorker, never on a handler thread.
#include <charconv>

#include <nlohmann/json.hpp>

#include "api_util.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/diagnosis/validation_request.h"
#include "stickslip/server/api.h"
#include "stickslip/store/store.h"

namespace stickslip::server {
namespace {

using nlohmann::json;
using store::StoreError;

const std::string kCollection = "/v1/validations";

json opt_text(const std::optional<std::string>& v) { return v ? json(*v) : json(nullptr); }

json validation_json(const store::JobRecord& rec, bool with_result, const JobScheduler* scheduler) {
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
      result = json::parse(*rec.result_json, nullptr, false);
      if (result.is_discarded()) result = nullptr;
    }
    j["result"] = std::move(result);
    // While it runs (the board is cleared just after the outcome is stored).
    const auto p = scheduler && rec.state == store::StudyState::kRunning ? scheduler->progress(rec.id) : std::nullopt;
    j["progress"] = p ? *p : json(nullptr);
  }
  return j;
}

Response unknown_validation(const std::string& id, const std::string& instance) {
  return detail::unknown_job("validation", "Validation", id, instance);
}

/// The stored validation (kind checked), or nullopt.
std::optional<store::JobRecord> find_validation(store::Store& store, const std::string& id) {
  auto job = store.get_job(id);
  if (!job || job->kind != "validation") return std::nullopt;
  return job;
}

Response trace_csv(const store::DiagnosisTrace& tr) {
  std::string csv = "t,Fd_measured,Fd_base,Fd_extended\n";
  csv.reserve(tr.t.size() * 48 + 40);
  for (std::size_t i = 0; i < tr.t.size(); ++i) {
    const double ext = tr.extended.empty() ? tr.base[i] : tr.extended[i];
    csv += detail::csv_number(tr.t[i]) + "," + detail::csv_number(tr.measured[i]) + "," +
           detail::csv_number(tr.base[i]) + "," + detail::csv_number(ext) + "\n";
  }
  return text_response(200, "text/csv; charset=utf-8", std::move(csv));
}

}  // namespace

JobResource Api::validation_resource(JobScheduler* scheduler) const {
  JobResource res;
  res.kind = "validation";
  res.collection = kCollection;
  res.list_key = "validations";
  res.noun = "validation";
  res.title = "Validation";
  res.request_noun = "a validation request";
  res.max_body_bytes = options_.max_diagnosis_body_bytes;
  res.max_body_option = "--max-diagnosis-body";
  res.scheduler = scheduler;
  res.detail_columns = {.request = false, .result = true};
  res.list_columns = {};
  res.to_json = [scheduler](const store::JobRecord& job, bool detail) {
    return validation_json(job, detail, scheduler);
  };
  res.check = [this](const json& doc, const Request&) -> std::variant<store::NewJob, Response> {
    const auto parsed = diagnosis::parse_validation_request(doc, options_.diagnosis_threads);
    if (!parsed.ok()) {
      return problem(422, "invalid-validation", "Invalid validation request",
                     std::to_string(parsed.errors.size()) + " problem(s) in the validation request: " +
                         common::to_string(parsed.errors),
                     detail::body_errors(parsed.errors), kCollection);
    }
    store::NewJob job;
    job.kind = "validation";
    job.name = parsed.request->data.name;
    job.request_json = doc.dump();
    job.request_hash = store::param_hash(job.request_json);
    return job;
  };
  return res;
}

void Api::add_validation_routes() {
  add_job_routes(validations_, [this](const Request& r, const std::string& id) {
    return get_job(r, validations_, id);
  });
  router_.add("GET", "/v1/validations/{id}/traces", [this](const Request& r, const PathParams& p) {
    return list_validation_traces(r, p.at("id"));
  });
  router_.add("GET", "/v1/validations/{id}/traces/{run}", [this](const Request& r, const PathParams& p) {
    return get_validation_trace(r, p.at("id"), p.at("run"));
  });
  router_.add("GET", "/v1/validation_request.schema.json", [](const Request&, const PathParams&) {
    Response resp = text_response(200, "application/schema+json",
                                  std::string(diagnosis::validation_request_schema_text()));
    resp.set_header("Cache-Control", "public, max-age=3600");
    return resp;
  });
  router_.add("GET", "/v1/validation.schema.json", [](const Request&, const PathParams&) {
    Response resp =
        text_response(200, "application/schema+json", std::string(diagnosis::validation_schema_text()));
    resp.set_header("Cache-Control", "public, max-age=3600");
    return resp;
  });
}

Response Api::list_validation_traces(const Request& r, const std::string& id) const {
  if (!detail::is_valid_id(id)) return unknown_validation(id, r.path());
  try {
    auto store = pool_.acquire();
    const auto rec = find_validation(*store, id);
    if (!rec) return unknown_validation(id, r.path());
    json runs = json::array();
    for (const auto& info : store->list_diagnosis_traces(id)) {
      const std::string self = kCollection + "/" + id + "/traces/" + std::to_string(info.run_index);
      runs.push_back({{"index", info.run_index},
                      {"run", info.run},
                      {"samples", info.samples},
                      {"t_first", detail::number_or_null(info.t_first)},
                      {"t_last", detail::number_or_null(info.t_last)},
                      {"links", {{"self", self}, {"csv", self + "?format=csv"}}}});
    }
    return json_response(200, {{"validation_id", id}, {"state", store::to_string(rec->state)}, {"runs", std::move(runs)}});
  } catch (const StoreError& e) {
    return detail::store_failure(e, r.path());
  }
}

Response Api::get_validation_trace(const Request& r, const std::string& id, const std::string& run) const {
  const auto format = detail::negotiate(r, true);
  if (!format) return detail::not_acceptable(r, true);
  if (!detail::is_valid_id(id)) return unknown_validation(id, r.path());
  std::int64_t index = -1;
  const auto [end, ec] = std::from_chars(run.data(), run.data() + run.size(), index);
  if (ec != std::errc{} || end != run.data() + run.size() || index < 0)
    return problem(404, "trace-not-found", "Trace not found",
                   "traces are numbered from 0 in manifest order (GET " + kCollection + "/" + id +
                       "/traces lists them), got \"" + run + "\"",
                   {}, r.path());
  try {
    auto store = pool_.acquire();
    if (!find_validation(*store, id)) return unknown_validation(id, r.path());
    const auto tr = store->get_diagnosis_trace(id, index);
    if (!tr)
      return problem(404, "trace-not-found", "Trace not found",
                     "validation " + id + " has no stored trace " + run + " (traces are stored when it succeeds)",
                     {}, r.path());
    if (*format == detail::Format::kCsv) return trace_csv(*tr);
    json t = json::array(), m = json::array(), b = json::array(), x = json::array();
    for (std::size_t i = 0; i < tr->t.size(); ++i) {
      t.push_back(detail::number_or_null(tr->t[i]));
      m.push_back(detail::number_or_null(tr->measured[i]));
      b.push_back(detail::number_or_null(tr->base[i]));
      x.push_back(detail::number_or_null(tr->extended.empty() ? tr->base[i] : tr->extended[i]));
    }
    return json_response(200, {{"validation_id", id}, {"index", index}, {"run", tr->run}, {"t", t},
                               {"Fd_measured", m}, {"Fd_base", b}, {"Fd_extended", x}});
  } catch (const StoreError& e) {
    return detail::store_failure(e, r.path());
  }
}

}  // namespace stickslip::server
