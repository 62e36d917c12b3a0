#pragma once
// The validation worker: the job worker (job_worker.h) for jobs of kind "validation" (POST
// /v1/validations, schemas/validation_request.schema.json), whose runner predicts the runs of a
// measured dataset with the calibrated models of a diagnosis (diagnosis::validate) and stores
// diagnosis::to_json of the result and, in the same transaction, each run's measured, base and
// extended series at every measured sample (GET /v1/validations/{id}/traces/{i}?format=csv).
// A request naming a diagnosis_id reads that diagnosis' stored result; a diagnosis that is not
// (or no longer) succeeded fails the validation with why. Cancel is immediate and a shutdown
// puts a running validation back to queued, as for diagnoses (diagnosis_worker.h).

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/diagnosis/validate.h"
#include "stickslip/server/job_worker.h"
#include "stickslip/server/progress_board.h"

namespace stickslip::server {

struct ValidationWorkerOptions {
  int threads = 0;                        ///< OpenMP threads per validation; 0 = OpenMP's default
  std::chrono::milliseconds poll{1000};   ///< how often the store is scanned without a notify
  int nice = 10;                          ///< nice value of the worker thread (see worker.h)
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// The series of a validation as the store keeps them (one per run, in manifest order).
std::vector<store::DiagnosisTrace> validation_traces(const diagnosis::Validation& v);

class ValidationWorker final : public JobWorker {
 public:
  ValidationWorker(std::filesystem::path db, ValidationWorkerOptions options,
                   std::shared_ptr<Health> health = nullptr);
  std::optional<nlohmann::json> progress(const std::string& id) const override;

 private:
  ValidationWorker(std::filesystem::path db, ValidationWorkerOptions options, std::shared_ptr<Health> health,
                   std::shared_ptr<ProgressBoard> board);
  std::shared_ptr<ProgressBoard> board_;
};

}  // namespace stickslip::server
