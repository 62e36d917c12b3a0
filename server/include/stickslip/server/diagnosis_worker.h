#pragma once
// The diagnosis worker: the job worker (job_worker.h) for jobs of kind "diagnosis", whose runner
// runs diagnosis::diagnose on the stored request (OpenMP inside) and stores diagnosis::to_json of
// the result (the diagnosis.json of `stickslip diagnose`) and, in the same transaction, each
// run's measured, base and extended series (the traces).
//
// - A diagnosis is one unit: interrupted, it reruns from the start.
// - Cancel is immediate: the diagnosis is marked cancelled in the store at once and asked to stop
//   through DiagnoseOptions::stop_requested, which diagnosis::diagnose polls before every model
//   evaluation; whatever result still comes is discarded.
// - Shutdown(grace): a running diagnosis is put back to queued at once and asked to stop; a
//   diagnose function that finishes within the grace still has its result stored; otherwise the
//   thread is detached and shutdown returns false, so the process can exit without waiting.
// - A stored request that no longer parses (e.g. the schema changed) fails with the errors.

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/server/job_worker.h"
#include "stickslip/server/progress_board.h"

namespace stickslip::server {

/// What a diagnosis leaves: the diagnosis.json document, and the series of each run that
/// `stickslip diagnose` plots (measured, base and extended model at the fit's sample times),
/// stored beside it for GET /v1/diagnoses/{id}/traces. Built implicitly from a document alone
/// (then no traces are stored).
struct DiagnosisOutput {
  DiagnosisOutput(nlohmann::json r) : result(std::move(r)) {}  // NOLINT: implicit on purpose
  DiagnosisOutput(nlohmann::json r, std::vector<store::DiagnosisTrace> t)
      : result(std::move(r)), traces(std::move(t)) {}
  nlohmann::json result;
  std::vector<store::DiagnosisTrace> traces;
};

/// The diagnosis as a function of the dataset and the options (injected so that tests can
/// control its timing). The worker passes options with keep_traces set.
using DiagnoseFn = std::function<DiagnosisOutput(const measured::MeasuredDataset&,
                                                 const diagnosis::DiagnoseOptions&)>;

/// diagnosis::to_json(diagnosis::diagnose(data, options)) and its series: what stickslipd runs.
DiagnosisOutput run_diagnosis(const measured::MeasuredDataset& data,
                              const diagnosis::DiagnoseOptions& options);
/// The series of a diagnosis as the store keeps them (one per run, in manifest order).
std::vector<store::DiagnosisTrace> diagnosis_traces(const diagnosis::Diagnosis& d);

struct DiagnosisWorkerOptions {
  int threads = 0;                        ///< OpenMP threads per diagnosis; 0 = OpenMP's default
  std::chrono::milliseconds poll{1000};   ///< how often the store is scanned without a notify
  int nice = 10;                          ///< nice value of the worker thread (see worker.h)

  /// True if every field holds. Otherwise appends one message per broken constraint, naming the
  /// field and the value, to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// The "run this job" step of a diagnosis: parses the stored request and calls fn; the
/// diagnosis' progress goes to board (may be null) while it runs.
RunJobFn diagnosis_runner(DiagnoseFn fn, int threads, std::shared_ptr<ProgressBoard> board = nullptr);

class DiagnosisWorker final : public JobWorker {
 public:
  DiagnosisWorker(std::filesystem::path db, DiagnosisWorkerOptions options, DiagnoseFn fn,
                  std::shared_ptr<Health> health = nullptr);
  /// The id of the diagnosis being computed now, if any.
  std::optional<std::string> running() const;
  /// The running diagnosis' progress (phase, models or candidates, evaluations, time left).
  std::optional<nlohmann::json> progress(const std::string& id) const override;

 private:
  DiagnosisWorker(std::filesystem::path db, DiagnosisWorkerOptions options, DiagnoseFn fn,
                  std::shared_ptr<Health> health, std::shared_ptr<ProgressBoard> board);
  std::shared_ptr<ProgressBoard> board_;
};

}  // namespace stickslip::server
