#pragma once
// The server's health as /healthz reports it: the job workers mark it degraded while they are
// paused by a persistent store fault (job_worker.h) and clear it when the store takes a write
// again. Thread-safe.

#include <chrono>
#include <map>
#include <mutex>
#include <optional>
#include <string>

namespace stickslip::server {

class Health {
 public:
  /// The worker of kind is paused by a store fault (error) and tries again in retry_in.
  void degrade(const std::string& kind, const std::string& error,
               std::chrono::milliseconds retry_in);
  /// The worker of kind wrote to the store again.
  void recover(const std::string& kind);
  /// nullopt when healthy; otherwise one line per paused worker.
  std::optional<std::string> problem() const;

 private:
  mutable std::mutex mu_;
  std::map<std::string, std::string> degraded_;  // kind -> what happened
};

}  // namespace stickslip::server
