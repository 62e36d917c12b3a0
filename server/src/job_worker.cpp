// One worker for every kind of job (job_worker.h).
#include "stickslip/server/job_worker.h"

#include <spdlog/spdlog.h>


#include <condition_variable>
#include <map>
#include <mutex>

#include "stickslip/common/text.h"
#include "stickslip/server/priority.h"

namespace stickslip::server {

using store::JobRecord;
using store::StoreError;
using store::StudyState;
using Clock = std::chrono::steady_clock;

const char* to_string(JobOutcome::Kind kind) noexcept {
  switch (kind) {
    case JobOutcome::Kind::kSucceeded: return "succeeded";
    case JobOutcome::Kind::kFailed: return "failed";
    case JobOutcome::Kind::kCancelled: return "cancelled";
    case JobOutcome::Kind::kStopped: return "stopped by shutdown, re-queued";
    case JobOutcome::Kind::kRecorded: return "finished";
    case JobOutcome::Kind::kStoreFault: return "stopped by a store fault, re-queued";
  }
  return "?";
}

CancelOutcome cancel_unclaimed(store::Store& store, const std::string& kind,
                               const std::string& id) {
  const auto rec = store.get_job(id);
  if (!rec || rec->kind != kind) return CancelOutcome::kNotFound;
  if (rec->state != StudyState::kQueued && rec->state != StudyState::kRunning)
    return CancelOutcome::kAlreadyFinished;
  store.set_job_state(id, StudyState::kCancelled);
  return CancelOutcome::kCancelled;
}

JobWorkerOptions one_at_a_time(std::string kind, std::chrono::milliseconds poll, int nice) {
  JobWorkerOptions j;
  j.kind = std::move(kind);
  j.concurrency = 1;
  j.poll = poll;
  j.nice = nice;
  j.cancel = CancelMode::kImmediate;
  return j;
}

bool JobWorkerOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  if (kind.empty()) fail("kind: empty");
  if (concurrency < 1) fail("concurrency: must be >= 1, got " + std::to_string(concurrency));
  if (poll.count() < 1) fail("poll: must be >= 1 ms, got " + std::to_string(poll.count()));
  if (nice < 0 || nice > 19) fail("nice: must be in [0, 19], got " + std::to_string(nice));
  if (backoff_first.count() < 1 || backoff_max < backoff_first)
    fail("backoff: need 1 ms <= backoff_first <= backoff_max, got backoff_first = " +
         std::to_string(backoff_first.count()) + " ms, backoff_max = " +
         std::to_string(backoff_max.count()) + " ms");
  return ok;
}

/// Everything the threads use, owned jointly by the worker and its threads, so that a detached
/// thread (shutdown with a short grace) never touches a destroyed worker.
struct JobWorker::Shared {
  struct Claim {
    std::atomic<bool> cancel{false};  // the user's cancel
    std::atomic<bool> stop{false};    // shutdown
  };

  std::filesystem::path db;
  JobWorkerOptions options;
  RunJobFn run;
  std::shared_ptr<Health> health;
  mutable std::mutex mu;
  std::condition_variable cv;
  bool stopping = false;
  int live = 0;  // threads that have not returned yet
  std::uint64_t notifications = 0;
  std::map<std::string, std::shared_ptr<Claim>> claims;
  std::atomic<std::size_t> finished{0};
  Clock::time_point paused_until{};
  std::chrono::milliseconds backoff{0};  // 0: not paused

  void loop();
  /// One pass over the queue under mu: the claimed job, nullopt when there is none; false in
  /// *ok when the store failed (the worker then pauses).
  std::optional<JobRecord> claim_next(std::unique_ptr<store::Store>& store,
                                      std::shared_ptr<Claim>* claim);
  JobOutcome run_one(store::Store& store, const JobRecord& job, const Claim& claim);
  void record(std::unique_ptr<store::Store>& store, const JobRecord& job, const JobOutcome& out);
  void pause(const std::string& error);    // under mu
  void resume_if_paused();                 // under mu
};

void JobWorker::Shared::pause(const std::string& error) {
  backoff = backoff.count() == 0 ? options.backoff_first
                                 : std::min(backoff * 2, options.backoff_max);
  paused_until = Clock::now() + backoff;
  spdlog::error("{} worker: store fault, pausing for {} ms: {}", options.kind, backoff.count(),
                error);
  if (health) health->degrade(options.kind, error, backoff);
}

void JobWorker::Shared::resume_if_paused() {
  if (backoff.count() == 0) return;
  backoff = std::chrono::milliseconds(0);
  spdlog::info("{} worker: the store works again", options.kind);
  if (health) health->recover(options.kind);
}

std::optional<JobRecord> JobWorker::Shared::claim_next(std::unique_ptr<store::Store>& store,
                                                       std::shared_ptr<Claim>* claim) {
  try {
    if (!store) store = std::make_unique<store::Store>(store::Store::open(db));
    // The indexed claim query: the oldest pending jobs, at most one more than this worker runs.
    for (const auto& id : store->pending_jobs(options.kind, claims.size() + 1)) {
      if (claims.count(id) > 0 || !store->claim_job(id)) continue;
      auto rec = store->get_job(id, {.request = true, .result = false});
      if (!rec) continue;
      *claim = std::make_shared<Claim>();
      claims[id] = *claim;
      resume_if_paused();
      return rec;
    }
    resume_if_paused();
  } catch (const StoreError& e) {
    store.reset();  // reopen on the next attempt
    pause(e.what());
  }
  return std::nullopt;
}

JobOutcome JobWorker::Shared::run_one(store::Store& store, const JobRecord& job,
                                      const Claim& claim) {
  JobContext ctx{job, db, store, claim.cancel, claim.stop};
  try {
    return run(ctx);
  } catch (const StoreError& e) {
    if (e.fault() != store::StoreFault::kNone) return {JobOutcome::Kind::kStoreFault, {}, e.what()};
    if (!claim.stop && !claim.cancel) return {JobOutcome::Kind::kFailed, {}, e.what()};
  } catch (const std::exception& e) {
    if (!claim.stop && !claim.cancel) return {JobOutcome::Kind::kFailed, {}, e.what()};
  }
  // Whatever failed under a stop or cancel request is that stop or cancel.
  return {claim.stop ? JobOutcome::Kind::kStopped : JobOutcome::Kind::kCancelled, {}, {}};
}

void JobWorker::Shared::record(std::unique_ptr<store::Store>& store, const JobRecord& job,
                               const JobOutcome& out) {
  using K = JobOutcome::Kind;
  bool stored = true;
  try {
    switch (out.kind) {
      case K::kSucceeded:
        stored = store->finish_job(job.id, StudyState::kSucceeded, out.result);
        break;
      case K::kFailed:
        stored = store->finish_job(job.id, StudyState::kFailed, {}, out.error);
        break;
      case K::kCancelled: stored = store->finish_job(job.id, StudyState::kCancelled, {}); break;
      case K::kStopped: store->requeue_job(job.id); break;
      case K::kRecorded: break;
      case K::kStoreFault:
        store->requeue_job(job.id, "store fault (the job resumes when the store works again): " +
                                       out.error.value_or(""));
        break;
    }
  } catch (const StoreError& e) {
    spdlog::error("{} {}: cannot record its outcome ({}): {}", job.kind, job.id,
                  to_string(out.kind), e.what());
    store.reset();
    std::lock_guard lock(mu);
    pause(e.what());
    return;
  }
  spdlog::info("{} {}: {}{}{}", job.kind, job.id, to_string(out.kind),
               stored ? "" : " (cancelled or finished meanwhile: outcome discarded)",
               out.error ? ": " + *out.error : std::string());
  if (out.kind == K::kStoreFault) {
    std::lock_guard lock(mu);
    pause(*out.error);
  }
}

void JobWorker::Shared::loop() {
  if (std::string why; !lower_thread_priority(options.nice, &why))
    spdlog::warn("{} worker: cannot lower its priority: {}", options.kind, why);
  std::unique_ptr<store::Store> store;
  while (true) {
    std::optional<JobRecord> job;
    std::shared_ptr<Claim> claim;
    {
      std::unique_lock lock(mu);
      if (stopping) break;
      if (Clock::now() < paused_until) {
        cv.wait_until(lock, paused_until, [&] { return stopping; });
        continue;
      }
      const std::uint64_t seen = notifications;
      job = claim_next(store, &claim);
      if (!job) {
        if (Clock::now() >= paused_until)
          cv.wait_for(lock, options.poll, [&] { return stopping || notifications != seen; });
        continue;
      }
    }
    const JobOutcome out = run_one(*store, *job, *claim);
    record(store, *job, out);
    {
      std::lock_guard lock(mu);
      claims.erase(job->id);
    }
    finished.fetch_add(1);
  }
  std::lock_guard lock(mu);
  --live;
  cv.notify_all();
}

JobWorker::JobWorker(std::filesystem::path db, JobWorkerOptions options, RunJobFn run,
                     std::shared_ptr<Health> health)
    : shared_(std::make_shared<Shared>()) {
  if (std::vector<std::string> errors; !options.IsValid(&errors))
    throw std::invalid_argument("JobWorkerOptions: " + common::join(errors, "; "));
  if (!run) throw std::invalid_argument("JobWorker: no run function");
  shared_->db = std::move(db);
  shared_->options = std::move(options);
  shared_->run = std::move(run);
  shared_->health = std::move(health);
}

JobWorker::~JobWorker() { shutdown(); }

void JobWorker::start() {
  std::lock_guard lock(shared_->mu);
  if (!threads_.empty() || shared_->stopping) return;
  for (int i = 0; i < shared_->options.concurrency; ++i) {
    ++shared_->live;
    threads_.emplace_back([s = shared_] { s->loop(); });
  }
}

bool JobWorker::shutdown(std::chrono::milliseconds grace) {
  std::vector<std::string> running;
  {
    std::lock_guard lock(shared_->mu);
    shared_->stopping = true;
    for (auto& [id, claim] : shared_->claims) {
      claim->stop = true;
      running.push_back(id);
    }
  }
  shared_->cv.notify_all();
  if (threads_.empty()) return true;
  // Back to queued at once, so the next start resumes them even if this process ends first.
  try {
    auto store = store::Store::open(shared_->db);
    for (const auto& id : running)
      if (store.requeue_job(id))
        spdlog::info("{} {}: interrupted by shutdown, re-queued", shared_->options.kind, id);
  } catch (const std::exception& e) {
    spdlog::error("{} worker: cannot re-queue its jobs: {}", shared_->options.kind, e.what());
  }
  bool done = false;
  {
    std::unique_lock lock(shared_->mu);
    const auto ended = [&] { return shared_->live == 0; };
    if (grace == std::chrono::milliseconds::max()) shared_->cv.wait(lock, ended);
    else shared_->cv.wait_for(lock, grace, ended);
    done = ended();
  }
  for (auto& t : threads_) done ? t.join() : t.detach();
  threads_.clear();
  return done;
}

void JobWorker::notify() {
  {
    std::lock_guard lock(shared_->mu);
    ++shared_->notifications;
  }
  shared_->cv.notify_all();
}

CancelOutcome JobWorker::cancel(store::Store& store, const std::string& id) {
  std::lock_guard lock(shared_->mu);
  const auto it = shared_->claims.find(id);
  if (it != shared_->claims.end() && shared_->options.cancel == CancelMode::kDeferred) {
    it->second->cancel = true;  // the runner commits its work and ends the job cancelled
    return CancelOutcome::kRequested;
  }
  // Not claimed (claim_next takes the same mutex), or kImmediate: the store decides now, and a
  // running job is also asked to stop.
  const CancelOutcome outcome = cancel_unclaimed(store, shared_->options.kind, id);
  if (outcome == CancelOutcome::kCancelled && it != shared_->claims.end())
    it->second->cancel = true;
  return outcome;
}

std::vector<std::string> JobWorker::running() const {
  std::lock_guard lock(shared_->mu);
  std::vector<std::string> ids;
  for (const auto& [id, claim] : shared_->claims) ids.push_back(id);
  return ids;
}

std::size_t JobWorker::finished() const noexcept { return shared_->finished.load(); }

const JobWorkerOptions& JobWorker::options() const noexcept { return shared_->options; }

}  // namespace stickslip::server
