// The local backend: OpenMP threads in this process (executor.h).
#include "stickslip/studies/executor.h"

#include <omp.h>

#include "stickslip/studies/compute.h"

namespace stickslip::studies {
namespace {

class LocalExecutor final : public Executor {
 public:
  void compute(const ComputeRequest& req, const RecordSink& sink, const StopFn& stop) override {
    const std::vector<Job> jobs =
        make_jobs(*req.spec, req.pending, batchable(*req.spec, req.measured));
    const long n = static_cast<long>(jobs.size());
    const int threads = req.threads > 0 ? req.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (long k = 0; k < n; ++k) {
      if (stop()) continue;
      std::vector<store::RunRecord> recs = compute_job(
          *req.spec, jobs[static_cast<std::size_t>(k)], req.study_id, req.measured,
          req.batched);
#pragma omp critical(stickslip_local_sink)
      {
        try {
          sink(std::move(recs));
        } catch (...) {  // no exception may leave the region; the sink's owner sees the failure
        }
      }
    }
  }
  std::string describe() const override { return "OpenMP"; }
};

}  // namespace

std::shared_ptr<Executor> local_executor() {
  static const std::shared_ptr<Executor> local = std::make_shared<LocalExecutor>();
  return local;
}

}  // namespace stickslip::studies
