#pragma once
// The live progress of the jobs a worker runs now (a diagnosis' or a validation's phase, item,
// evaluations and estimate; diagnosis::Progress), kept in memory by the worker's runner and read
// by the API for GET /v1/diagnoses/{id} and GET /v1/validations/{id} (JobScheduler::progress).
// It is not stored: it means nothing once the job ends or the process stops.

#include <map>
#include <mutex>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "stickslip/diagnosis/diagnose.h"

namespace stickslip::server {

class ProgressBoard {
 public:
  void set(const std::string& id, const diagnosis::Progress& p);
  void erase(const std::string& id);
  std::optional<nlohmann::json> get(const std::string& id) const;

 private:
  mutable std::mutex mu_;
  std::map<std::string, nlohmann::json> board_;
};

/// A Progress as the API shows it (numbers that are not finite as null).
nlohmann::json progress_json(const diagnosis::Progress& p);

}  // namespace stickslip::server
