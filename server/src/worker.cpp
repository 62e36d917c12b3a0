#include "stickslip/server/worker.h"

#include <spdlog/spdlog.h>

#include "stickslip/common/text.h"


namespace stickslip::server {

bool WorkerOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  if (concurrency < 1) fail("concurrency: must be >= 1, got " + std::to_string(concurrency));
  if (threads < 0) fail("threads: must be >= 0, got " + std::to_string(threads));
  if (poll.count() < 1) fail("poll: must be >= 1 ms, got " + std::to_string(poll.count()));
  if (nice < 0 || nice > 19) fail("nice: must be in [0, 19], got " + std::to_string(nice));
  if (execution.retries < 0)
    fail("launcher retries: must be >= 0, got " + std::to_string(execution.retries));
  if (execution.chunk_deadline_s < 0)
    fail("chunk deadline: must be >= 0 s, got " + std::to_string(execution.chunk_deadline_s));
  return ok;
}

RunJobFn study_runner(RunStudyFn run, const WorkerOptions& options) {
  return [run = std::move(run), options](JobContext& ctx) -> JobOutcome {
    const std::string& id = ctx.job.id;
    auto parsed = studies::parse_study(ctx.job.request_json.value_or(""), options.limits);
    if (!parsed.ok())
      return {JobOutcome::Kind::kFailed, {},
              "stored spec is invalid: " + common::to_string(parsed.errors)};
    spdlog::info("study {} ({}): starting, {} runs", id, ctx.job.name, ctx.job.progress.total);
    studies::RunnerOptions ro;
    ro.threads = options.threads;
    ro.writer = options.writer;
    ro.cancel = &ctx.cancel;
    ro.stop = &ctx.stop;
    ro.execution = options.execution;
    ro.on_retry = [&id](int attempt, const std::string& why) {
      spdlog::warn("study {}: attempt {} lost work ({}); starting it again for the missing runs",
                   id, attempt, why);
    };
    const auto summary = run(ctx.db, id, *parsed.spec, ro);
    spdlog::info("study {}: {} ({} computed, {} failed, {} already stored) in {:.3f} s{}{}", id,
                 studies::to_string(summary.outcome), summary.computed, summary.failed,
                 summary.skipped, summary.wall_s, summary.error.empty() ? "" : ": ",
                 summary.error);
    // run_study stores succeeded, cancelled and failed itself; stopped studies go back to the
    // queue, and a study stopped by the store stays resumable.
    if (summary.outcome == studies::RunOutcome::kStopped)
      return {JobOutcome::Kind::kStopped, {}, {}};
    if (summary.outcome == studies::RunOutcome::kFailed &&
        summary.store_fault != store::StoreFault::kNone)
      return {JobOutcome::Kind::kStoreFault, {}, summary.error};
    return {JobOutcome::Kind::kRecorded, {}, {}};
  };
}

namespace {
JobWorkerOptions job_options(const WorkerOptions& o) {
  if (std::vector<std::string> errors; !o.IsValid(&errors))
    throw std::invalid_argument("WorkerOptions: " + common::join(errors, "; "));
  JobWorkerOptions j;
  j.kind = "study";
  j.concurrency = o.concurrency;
  j.poll = o.poll;
  j.nice = o.nice;
  j.cancel = CancelMode::kDeferred;
  return j;
}
}  // namespace

Worker::Worker(std::filesystem::path db, WorkerOptions options, RunStudyFn run,
               std::shared_ptr<Health> health)
    : JobWorker(std::move(db), job_options(options),
                run ? study_runner(std::move(run), options) : RunJobFn{}, std::move(health)) {}

}  // namespace stickslip::server
