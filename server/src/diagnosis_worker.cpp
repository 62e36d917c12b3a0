#include "stickslip/server/diagnosis_worker.h"

#include <spdlog/spdlog.h>


#include "stickslip/common/text.h"
#include "stickslip/diagnosis/diagnosis_request.h"

namespace stickslip::server {

std::vector<store::DiagnosisTrace> diagnosis_traces(const diagnosis::Diagnosis& d) {
  std::vector<store::DiagnosisTrace> out;
  out.reserve(d.series.size());
  for (const auto& s : d.series) out.push_back({s.name, s.t, s.measured, s.base, s.extended});
  return out;
}

DiagnosisOutput run_diagnosis(const measured::MeasuredDataset& data,
                              const diagnosis::DiagnoseOptions& options) {
  const diagnosis::Diagnosis d = diagnosis::diagnose(data, options);
  return {diagnosis::to_json(d), diagnosis_traces(d)};
}

bool DiagnosisWorkerOptions::IsValid(std::vector<std::string>* errors) const {
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

namespace {

/// The stored request, checked again as the API checked it; the errors when it no longer parses.
std::optional<diagnosis::DiagnosisRequest> stored_request(const std::string& text, int threads,
                                                          std::vector<common::SpecError>* errors) {
  const auto doc = common::parse_json(text, errors);
  if (!doc) return std::nullopt;
  auto parsed = diagnosis::parse_diagnosis_request(*doc, threads);
  *errors = std::move(parsed.errors);
  return std::move(parsed.request);
}

}  // namespace

RunJobFn diagnosis_runner(DiagnoseFn fn, int threads, std::shared_ptr<ProgressBoard> board) {
  return [fn = std::move(fn), threads, board](JobContext& ctx) -> JobOutcome {
    const std::string& id = ctx.job.id;
    std::vector<common::SpecError> errors;
    auto request = stored_request(ctx.job.request_json.value_or(""), threads, &errors);
    if (!request)
      return {JobOutcome::Kind::kFailed, {},
              "stored request is invalid: " + common::to_string(errors)};
    spdlog::info("diagnosis {} ({}): starting, {} runs", id, request->data.name,
                 request->data.runs.size());
    diagnosis::DiagnoseOptions options = request->options;
    options.stop_requested = [&ctx] { return ctx.should_stop(); };
    options.keep_traces = true;  // stored beside the result (GET .../traces)
    if (board) options.progress = [board, id](const diagnosis::Progress& p) { board->set(id, p); };
    struct Erase {  // the progress means nothing once the run ends, however it ends
      ProgressBoard* b;
      const std::string& id;
      ~Erase() {
        if (b) b->erase(id);
      }
    } erase{board.get(), id};
    const auto t0 = std::chrono::steady_clock::now();
    std::optional<DiagnosisOutput> out;
    try {
      out.emplace(fn(request->data, options));
    } catch (const std::exception& e) {
      // Told to stop (DiagnosisCancelled, or whatever failed under the stop): the job worker
      // counts it as the stop or cancel; otherwise e.g. a dataset diagnose cannot use.
      if (ctx.should_stop()) throw;
      return {JobOutcome::Kind::kFailed, {}, e.what()};
    }
    // The result and the traces in one transaction, only while it is queued or running.
    const bool stored = ctx.store.finish_diagnosis(id, store::StudyState::kSucceeded,
                                                   out->result.dump(), std::nullopt, out->traces);
    spdlog::info("diagnosis {}: computed in {:.1f} s{}", id,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                 stored ? "" : "; cancelled (or finished) meanwhile, result discarded");
    return {JobOutcome::Kind::kRecorded, {}, {}};
  };
}

namespace {
JobWorkerOptions job_options(const DiagnosisWorkerOptions& o) {
  if (std::vector<std::string> errors; !o.IsValid(&errors))
    throw std::invalid_argument("DiagnosisWorkerOptions: " + common::join(errors, "; "));
  return one_at_a_time("diagnosis", o.poll, o.nice);
}
}  // namespace

DiagnosisWorker::DiagnosisWorker(std::filesystem::path db, DiagnosisWorkerOptions options,
                                 DiagnoseFn fn, std::shared_ptr<Health> health)
    : DiagnosisWorker(std::move(db), std::move(options), std::move(fn), std::move(health),
                      std::make_shared<ProgressBoard>()) {}

DiagnosisWorker::DiagnosisWorker(std::filesystem::path db, DiagnosisWorkerOptions options,
                                 DiagnoseFn fn, std::shared_ptr<Health> health,
                                 std::shared_ptr<ProgressBoard> board)
    : JobWorker(std::move(db), job_options(options),
                fn ? diagnosis_runner(std::move(fn), options.threads, board) : RunJobFn{},
                std::move(health)),
      board_(std::move(board)) {}

std::optional<nlohmann::json> DiagnosisWorker::progress(const std::string& id) const {
  return board_->get(id);
}

std::optional<std::string> DiagnosisWorker::running() const {
  const auto ids = JobWorker::running();
  if (ids.empty()) return std::nullopt;
  return ids.front();
}

}  // namespace stickslip::server
