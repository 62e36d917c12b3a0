#include "stickslip/server/worker.h"

#include <spdlog/spdlog.h>

#include "stickslip/server/priority.h"

namespace stickslip::server {

using store::StudyState;


bool WorkerOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (concurrency < 1) return fail("concurrency: must be >= 1, got " + std::to_string(concurrency));
  if (threads < 0) return fail("threads: must be >= 0, got " + std::to_string(threads));
  if (poll.count() < 1) return fail("poll: must be >= 1 ms");
  if (nice < 0 || nice > 19) return fail("nice: must be in [0, 19], got " + std::to_string(nice));
  return true;
}

Worker::Worker(std::filesystem::path db, WorkerOptions options, RunStudyFn run)
    : db_(std::move(db)), options_(std::move(options)), run_(std::move(run)) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument("WorkerOptions: " + why);
  if (!run_) throw std::invalid_argument("Worker: no run function");
}

Worker::~Worker() { shutdown(); }

void Worker::start() {
  std::lock_guard lock(mu_);
  if (!threads_.empty() || stopping_) return;
  for (int i = 0; i < options_.concurrency; ++i) threads_.emplace_back([this] { loop(); });
}

void Worker::shutdown() {
  std::vector<std::thread> threads;
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
    for (auto& [id, claim] : claims_) claim->stop.store(true);
    threads.swap(threads_);
  }
  cv_.notify_all();
  for (auto& t : threads) t.join();
}

void Worker::notify() {
  {
    std::lock_guard lock(mu_);
    ++notifications_;
  }
  cv_.notify_all();
}

CancelOutcome Worker::cancel(store::Store& store, const std::string& id) {
  std::lock_guard lock(mu_);
  if (const auto it = claims_.find(id); it != claims_.end()) {
    it->second->cancel.store(true);
    return CancelOutcome::kRequested;
  }
  // Not claimed; claim_next takes the same mutex and re-reads the state, so no worker can pick
  // the study up between this check and the store update.
  return cancel_unclaimed(store, id);
}

std::vector<std::string> Worker::running() const {
  std::lock_guard lock(mu_);
  std::vector<std::string> ids;
  for (const auto& [id, claim] : claims_) ids.push_back(id);
  return ids;
}

std::string Worker::claim_next(store::Store& store, std::shared_ptr<Claim>* claim) {
  // The store is the queue: scan studies in id (= creation) order for unfinished ones.
  std::string after;
  constexpr std::size_t kPage = 256;
  while (true) {
    const auto page = store.list_studies(kPage, after);
    for (const auto& rec : page) {
      if (rec.state != StudyState::kQueued && rec.state != StudyState::kRunning) continue;
      if (claims_.count(rec.id) > 0) continue;
      *claim = std::make_shared<Claim>();
      claims_[rec.id] = *claim;
      return rec.id;
    }
    if (page.size() < kPage) return {};
    after = page.back().id;
  }
}

void Worker::loop() {
  // Threads it creates (the compute thread and libgomp team of run_study) inherit it.
  if (std::string why; !lower_thread_priority(options_.nice, &why))
    spdlog::warn("worker: cannot lower its priority: {}", why);
  std::unique_ptr<store::Store> store;
  while (true) {
    std::string id;
    std::shared_ptr<Claim> claim;
    {
      std::unique_lock lock(mu_);
      if (stopping_) return;
      const std::uint64_t seen = notifications_;
      try {
        if (!store) store = std::make_unique<store::Store>(store::Store::open(db_));
        id = claim_next(*store, &claim);
      } catch (const std::exception& e) {
        spdlog::error("worker: cannot read the study queue: {}", e.what());
        store.reset();  // reopen on the next attempt
      }
      if (id.empty()) {
        cv_.wait_for(lock, options_.poll,
                     [&] { return stopping_ || notifications_ != seen; });
        continue;
      }
    }
    run_one(*store, id, claim);
    {
      std::lock_guard lock(mu_);
      claims_.erase(id);
    }
    finished_.fetch_add(1);
  }
}

void Worker::run_one(store::Store& store, const std::string& id,
                     const std::shared_ptr<Claim>& claim) {
  try {
    const auto rec = store.get_study(id);
    if (!rec) return;
    auto parsed = studies::parse_study(rec->spec_json, options_.limits);
    if (!parsed.ok()) {
      spdlog::error("study {}: stored spec is invalid: {}", id, to_string(parsed.errors));
      store.set_study_state(id, StudyState::kFailed,
                            "stored spec is invalid: " + to_string(parsed.errors));
      return;
    }
    spdlog::info("study {} ({}): starting, {} runs", id, rec->name, rec->total_runs);
    studies::RunnerOptions ro;
    ro.threads = options_.threads;
    ro.writer = options_.writer;
    ro.cancel = &claim->cancel;
    ro.stop = &claim->stop;
    const auto summary = run_(db_, id, *parsed.spec, ro);
    // Stopped by shutdown: run_study leaves it running; mark it queued (it is not running while
    // the server is down) so the next start resumes it either way.
    const bool put_back = summary.outcome == studies::RunOutcome::kStopped;
    if (put_back) store.set_study_state(id, StudyState::kQueued);
    spdlog::info("study {}: {} ({} computed, {} failed, {} already stored) in {:.3f} s{}{}", id,
                 put_back ? "interrupted by shutdown, re-queued" : studies::to_string(summary.outcome),
                 summary.computed, summary.failed, summary.skipped, summary.wall_s,
                 summary.error.empty() ? "" : ": ", summary.error);
  } catch (const std::exception& e) {
    // run_study does not throw for a run's failure; this is the store or the spec failing.
    spdlog::error("study {}: {}", id, e.what());
    try {
      store.set_study_state(id, StudyState::kFailed, e.what());
    } catch (const std::exception& e2) {
      spdlog::error("study {}: cannot mark it failed: {}", id, e2.what());
    }
  }
}

}  // namespace stickslip::server
