#pragma once
// Computing the runs of a study, without any store: one run (compute_run, runner.h), the jobs
// the runs are grouped into (make_jobs) and one job (compute_job). Every backend of the runner
// (executor.h: OpenMP in this process, MPI ranks, a launched MPI job) computes through these
// functions, so a run's stored result depends only on the spec and its design index.
//
// A job is one run, or several rk4 runs that the engine computes at once in SIMD lanes
// (engine/batch.h); batched results are bitwise equal to simulate(), so the grouping changes
// speed only, never a result.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "stickslip/measured/measured.h"
#include "stickslip/store/store.h"
#include "stickslip/studies/spec.h"

namespace stickslip::studies {

/// Design indices computed together (one engine call); see make_jobs.
using Job = std::vector<std::size_t>;

/// Whether the study's runs may be batched: it integrates with rk4 and needs no trace (no stored
/// traces, no measured data to compare with).
bool batchable(const StudySpec& spec, const measured::MeasuredDataset* measured);

/// Groups the pending runs into jobs: runs whose configurations can share a batch (same model,
/// dt and base motion; engine/batch.h), up to the engine's lane count; every other run is a job
/// of one (all of them when batch is false). The grouping depends only on the spec and the
/// pending set, never on threads or ranks.
std::vector<Job> make_jobs(const StudySpec& spec, const std::vector<std::size_t>& pending,
                           bool batch);

/// Computes one job: a batch with one simulate_batch call, else run by run (compute_run).
/// Never throws: a run that cannot be computed is stored as "invalid" with the reason. Adds the
/// number of runs computed in batched mode to *batched when it is non-null.
std::vector<store::RunRecord> compute_job(const StudySpec& spec, const Job& job,
                                          const std::string& study_id,
                                          const measured::MeasuredDataset* measured,
                                          std::atomic<std::int64_t>* batched = nullptr);

}  // namespace stickslip::studies
