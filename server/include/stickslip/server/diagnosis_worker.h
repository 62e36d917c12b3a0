#pragma once
// The diagnosis worker: one thread of its own (never an HTTP I/O or handler thread) that takes
// queued diagnoses from the store in creation order and runs studies::diagnose on each (OpenMP
// inside), storing studies::to_json of the result (the diagnosis.json of `stickslip diagnose`)
// and, in the same transaction, each run's measured, base and extended series (the traces).
//
// - The store is the queue: diagnoses in state queued or running (running = interrupted by a
//   crash or a shutdown) are picked up in id (= creation) order, so after a restart every
//   unfinished diagnosis runs again by itself. A diagnosis is one unit: it reruns from the start.
// - A diagnosis is claimed under a mutex, which also switches it to running in the store; a
//   cancel takes the same mutex, so it either cancels a waiting diagnosis in the store or finds
//   it claimed.
// - Cancelling a running diagnosis marks it cancelled in the store at once and asks the
//   computation to stop: the options passed to the diagnose function carry a stop_requested
//   callback (DiagnoseOptions), which studies::diagnose polls before every model evaluation, so
//   it ends within one evaluation per thread (DiagnosisCancelled) and the worker takes the next
//   diagnosis. Whatever result a diagnose function still returns is discarded (the store only
//   accepts a result while the diagnosis is queued or running).
// - shutdown(grace): no diagnosis is claimed any more; a running one is put back to queued in
//   the store at once (so the next start reruns it) and asked to stop, then the thread gets
//   `grace` to end. A diagnose function that ignores the callback and finishes within the grace
//   has its result stored; if the thread does not end in time it is detached (it owns
//   everything it uses) and shutdown returns false, so the process can exit without waiting.
// - A stored request that no longer parses (e.g. the schema changed) fails with the errors.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "stickslip/server/scheduler.h"
#include "stickslip/diagnosis/diagnose.h"

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

/// What the HTTP handlers need from the diagnosis worker.
class DiagnosisScheduler {
 public:
  virtual ~DiagnosisScheduler() = default;
  /// A diagnosis was queued: look at the store now rather than at the next poll.
  virtual void notify_diagnosis() = 0;
  /// Cancels a diagnosis (queued or running -> cancelled); store is the caller's connection.
  virtual CancelOutcome cancel_diagnosis(store::Store& store, const std::string& id) = 0;
};

/// Cancellation without a worker: queued or running -> cancelled; terminal: unchanged.
CancelOutcome cancel_diagnosis_unclaimed(store::Store& store, const std::string& id);

struct DiagnosisWorkerOptions {
  int threads = 0;                        ///< OpenMP threads per diagnosis; 0 = OpenMP's default
  std::chrono::milliseconds poll{1000};   ///< how often the store is scanned without a notify
  int nice = 10;                          ///< nice value of the worker thread (see worker.h)

  bool IsValid(std::string* why) const;
};

class DiagnosisWorker final : public DiagnosisScheduler {
 public:
  DiagnosisWorker(std::filesystem::path db, DiagnosisWorkerOptions options, DiagnoseFn fn);
  ~DiagnosisWorker() override;  ///< shutdown() with an unlimited grace
  DiagnosisWorker(const DiagnosisWorker&) = delete;
  DiagnosisWorker& operator=(const DiagnosisWorker&) = delete;

  /// Starts the worker thread (once).
  void start();
  /// See the header comment. Idempotent. true: the thread has ended; false: it was detached.
  bool shutdown(std::chrono::milliseconds grace = std::chrono::milliseconds::max());

  void notify_diagnosis() override;
  CancelOutcome cancel_diagnosis(store::Store& store, const std::string& id) override;

  /// The id of the diagnosis being computed now, if any.
  std::optional<std::string> running() const;
  /// Diagnoses finished by this worker (any outcome) since start.
  std::size_t finished() const noexcept;

  struct Shared;

 private:
  std::shared_ptr<Shared> shared_;
  std::thread thread_;
};

}  // namespace stickslip::server
