#pragma once
// Rank 0's backend (session.h): the dedicated master.
#include <atomic>
#include <memory>
#include <mutex>

#include "stickslip/studies/chunks.h"
#include "stickslip/studies/executor.h"

namespace stickslip::mpi::detail {

class MasterExecutor final : public studies::Executor {
 public:
  MasterExecutor(int workers, studies::ChunkOptions chunks,
                 std::shared_ptr<std::atomic<bool>> broken)
      : workers_(workers), chunks_(chunks), broken_(std::move(broken)) {}
  /// Hands the study's jobs to the worker ranks in chunks (chunks.h) and delivers their runs.
  /// Throws ExecutorError (and breaks the session) when a rank misses its chunk's deadline,
  /// cannot compute the study or sends something else than it was asked for.
  void compute(const studies::ComputeRequest& req, const studies::RecordSink& sink,
               const studies::StopFn& stop) override;
  std::string describe() const override;
  std::string running_note() const override;

 private:
  std::mutex mu_;
  int workers_;
  studies::ChunkOptions chunks_;
  std::shared_ptr<std::atomic<bool>> broken_;
};

}  // namespace stickslip::mpi::detail
