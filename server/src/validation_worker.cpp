#include "stickslip/server/validation_worker.h"

#include <spdlog/spdlog.h>

#include "stickslip/common/text.h"
#include "stickslip/diagnosis/validation_request.h"

namespace stickslip::server {

bool ValidationWorkerOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  if (threads < 0) fail("threads: must be >= 0, got " + std::to_string(threads));
  if (poll.count() < 1) fail("poll: must be >= 1 ms, got " + std::to_string(poll.count()));
  if (nice < 0 || nice > 19) fail("nice: must be in [0, 19], got " + std::to_string(nice));
  return ok;
}

std::vector<store::DiagnosisTrace> validation_traces(const diagnosis::Validation& v) {
  std::vector<store::DiagnosisTrace> out;
  for (const auto& r : v.runs)
    if (r.base.size() == r.t.size() && r.extended.size() == r.t.size())
      out.push_back({r.run, r.t, r.measured, r.base, r.extended});
    else  // a failed run: its measured series alone, the models' as NaN
      out.push_back({r.run, r.t, r.measured, std::vector<double>(r.t.size(), std::nan("")), {}});
  return out;
}

namespace {

/// The diagnosis document a request names: its own, or the stored result of diagnosis_id.
std::optional<nlohmann::json> diagnosis_document(const diagnosis::ValidationRequest& r, store::Store& store,
                                                 std::string* why) {
  if (r.diagnosis) return r.diagnosis;
  const auto job = store.get_job(r.diagnosis_id, {.request = false, .result = true});
  if (!job || job->kind != "diagnosis") {
    *why = "diagnosis_id " + r.diagnosis_id + ": no such diagnosis";
    return std::nullopt;
  }
  if (job->state != store::StudyState::kSucceeded || !job->result_json) {
    *why = "diagnosis_id " + r.diagnosis_id + ": the diagnosis is " + store::to_string(job->state) +
           ", not succeeded";
    return std::nullopt;
  }
  nlohmann::json doc = nlohmann::json::parse(*job->result_json, nullptr, false);
  if (const auto e = diagnosis::check_diagnosis_models(doc, "/diagnosis"); !e.empty()) {
    *why = "diagnosis_id " + r.diagnosis_id + ": " + common::to_string(e);
    return std::nullopt;
  }
  return doc;
}

RunJobFn validation_runner(int threads, std::shared_ptr<ProgressBoard> board) {
  return [threads, board](JobContext& ctx) -> JobOutcome {
    const std::string& id = ctx.job.id;
    std::vector<common::SpecError> errors;
    const auto doc = common::parse_json(ctx.job.request_json.value_or(""), &errors);
    auto parsed = doc ? diagnosis::parse_validation_request(*doc, threads) : diagnosis::ParsedValidationRequest{};
    if (!parsed.ok())
      return {JobOutcome::Kind::kFailed, {},
              "stored request is invalid: " + common::to_string(doc ? parsed.errors : errors)};
    std::string why;
    const auto diag = diagnosis_document(*parsed.request, ctx.store, &why);
    if (!diag) return {JobOutcome::Kind::kFailed, {}, why};
    diagnosis::ValidateOptions o = parsed.request->options;
    o.stop_requested = [&ctx] { return ctx.should_stop(); };
    o.progress = [board, id](const diagnosis::Progress& p) { board->set(id, p); };
    struct Erase {
      ProgressBoard* b;
      const std::string& id;
      ~Erase() { b->erase(id); }
    } erase{board.get(), id};
    spdlog::info("validation {} ({}): starting, {} runs", id, parsed.request->data.name,
                 parsed.request->data.runs.size());
    std::optional<diagnosis::Validation> v;
    try {
      v.emplace(diagnosis::validate(*diag, parsed.request->data, o));
    } catch (const std::exception& e) {
      if (ctx.should_stop()) throw;
      return {JobOutcome::Kind::kFailed, {}, e.what()};
    }
    const bool stored = ctx.store.finish_diagnosis(id, store::StudyState::kSucceeded, diagnosis::to_json(*v).dump(),
                                                   std::nullopt, validation_traces(*v));
    spdlog::info("validation {}: computed in {:.1f} s{}", id, v->seconds,
                 stored ? "" : "; cancelled (or finished) meanwhile, result discarded");
    return {JobOutcome::Kind::kRecorded, {}, {}};
  };
}

JobWorkerOptions job_options(const ValidationWorkerOptions& o) {
  if (std::vector<std::string> errors; !o.IsValid(&errors))
    throw std::invalid_argument("ValidationWorkerOptions: " + common::join(errors, "; "));
  return one_at_a_time("validation", o.poll, o.nice);
}

}  // namespace

ValidationWorker::ValidationWorker(std::filesystem::path db, ValidationWorkerOptions options,
                                   std::shared_ptr<Health> health)
    : ValidationWorker(std::move(db), std::move(options), std::move(health), std::make_shared<ProgressBoard>()) {}

ValidationWorker::ValidationWorker(std::filesystem::path db, ValidationWorkerOptions options,
                                   std::shared_ptr<Health> health, std::shared_ptr<ProgressBoard> board)
    : JobWorker(std::move(db), job_options(options), validation_runner(options.threads, board), std::move(health)),
      board_(std::move(board)) {}

std::optional<nlohmann::json> ValidationWorker::progress(const std::string& id) const { return board_->get(id); }

}  // namespace stickslip::server
