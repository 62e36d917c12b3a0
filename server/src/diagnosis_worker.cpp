#include "stickslip/server/diagnosis_worker.h"

#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "stickslip/diagnosis/diagnosis_request.h"

namespace stickslip::server {

using store::StudyState;

std::vector<store::DiagnosisTrace> diagnosis_traces(const diagnosis::Diagnosis& d) {
  std::vector<store::DiagnosisTrace> out;
  out.reserve(d.series.size());
  for (const auto& s : d.series) out.push_back({s.name, s.t, s.measured, s.base, s.extended});
  return out;
}

DiagnosisOutput run_diagnosis(const measured::MeasuredDataset& data,
                              const diagnosis::DiagnoseOptions& options) {
  const diagnosis::Diagnosis d = diagnosis::diagnose(data, options);
  return {diagnosis::to_json(d), diagnosis_traces(d)};
}

CancelOutcome cancel_diagnosis_unclaimed(store::Store& store, const std::string& id) {
  const auto rec = store.get_diagnosis(id);
  if (!rec) return CancelOutcome::kNotFound;
  if (rec->state != StudyState::kQueued && rec->state != StudyState::kRunning)
    return CancelOutcome::kAlreadyFinished;
  store.set_diagnosis_state(id, StudyState::kCancelled);
  return CancelOutcome::kCancelled;
}

bool DiagnosisWorkerOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (threads < 0) return fail("threads: must be >= 0, got " + std::to_string(threads));
  if (poll.count() < 1) return fail("poll: must be >= 1 ms");
  if (nice < 0 || nice > 19) return fail("nice: must be in [0, 19], got " + std::to_string(nice));
  return true;
}

/// Everything the thread uses, owned jointly by the worker and its thread, so that a detached
/// thread (shutdown with a short grace) never touches a destroyed worker.
struct DiagnosisWorker::Shared {
  std::filesystem::path db;
  DiagnosisWorkerOptions options;
  DiagnoseFn fn;
  mutable std::mutex mu;
  std::condition_variable cv;
  bool stopping = false;
  bool done = false;  // the thread has returned
  std::uint64_t notifications = 0;
  std::optional<std::string> running;
  /// Set (under mu) when the running diagnosis is cancelled or the worker shuts down; polled by
  /// studies::diagnose through DiagnoseOptions::stop_requested, from its OpenMP threads.
  std::atomic<bool> stop_running{false};
  std::atomic<std::size_t> finished{0};

  /// Under mu: the first queued or running diagnosis, switched to running; empty when none.
  std::string claim_next(store::Store& store) {
    std::string after;
    constexpr std::size_t kPage = 256;
    while (true) {
      const auto page = store.list_diagnoses(kPage, after);
      for (const auto& rec : page) {
        if (rec.state != StudyState::kQueued && rec.state != StudyState::kRunning) continue;
        store.set_diagnosis_state(rec.id, StudyState::kRunning);
        running = rec.id;
        stop_running = stopping;
        return rec.id;
      }
      if (page.size() < kPage) return {};
      after = page.back().id;
    }
  }

  void run_one(store::Store& store, const std::string& id) {
    try {
      const auto text = store.get_diagnosis_request(id);
      if (!text) return;
      std::vector<common::SpecError> errors;
      const auto doc = common::parse_json(*text, &errors);
      std::optional<diagnosis::DiagnosisRequest> request;
      if (doc) {
        auto parsed = diagnosis::parse_diagnosis_request(*doc, options.threads);
        errors = std::move(parsed.errors);
        request = std::move(parsed.request);
      }
      if (!request) {
        const std::string why = "stored request is invalid: " + common::to_string(errors);
        spdlog::error("diagnosis {}: {}", id, why);
        store.finish_diagnosis(id, StudyState::kFailed, std::nullopt, why);
        return;
      }
      spdlog::info("diagnosis {} ({}): starting, {} runs", id, request->data.name,
                   request->data.runs.size());
      const auto t0 = std::chrono::steady_clock::now();
      std::optional<std::string> result, error;
      std::vector<store::DiagnosisTrace> traces;
      diagnosis::DiagnoseOptions diag_options = request->options;
      diag_options.stop_requested = [this] { return stop_running.load(); };
      diag_options.keep_traces = true;  // stored beside the result (GET .../traces)
      try {
        DiagnosisOutput out = fn(request->data, diag_options);
        result = out.result.dump();
        traces = std::move(out.traces);
      } catch (const std::exception& e) {
        if (stop_running) {
          // Told to stop (studies::DiagnosisCancelled, or whatever failed under the stop): it
          // was cancelled (already so in the store) or is shutting down (already re-queued),
          // so nothing is stored; if the re-queue failed it is still running in the store and
          // reruns at the next start.
          spdlog::info("diagnosis {}: stopped after {:.1f} s ({})", id,
                       std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                       e.what());
          return;
        }
        error = e.what();  // e.g. std::invalid_argument: a dataset diagnose cannot use
      }
      const double secs =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const bool stored = store.finish_diagnosis(
          id, result ? StudyState::kSucceeded : StudyState::kFailed, result, error, traces);
      spdlog::info("diagnosis {}: {} in {:.1f} s{}{}", id,
                   !stored ? "cancelled (or finished elsewhere) meanwhile, result discarded"
                           : (result ? "succeeded" : "failed"),
                   secs, error ? ": " : "", error.value_or(""));
    } catch (const std::exception& e) {  // the store failing
      spdlog::error("diagnosis {}: {}", id, e.what());
      try {
        store.finish_diagnosis(id, StudyState::kFailed, std::nullopt, e.what());
      } catch (const std::exception& e2) {
        spdlog::error("diagnosis {}: cannot mark it failed: {}", id, e2.what());
      }
    }
  }

  void loop() {
    if (options.nice > 0) {
      const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
      if (::setpriority(PRIO_PROCESS, tid, options.nice) != 0)
        spdlog::warn("diagnosis worker: cannot lower its priority: {}", std::strerror(errno));
    }
    std::unique_ptr<store::Store> store;
    while (true) {
      std::string id;
      {
        std::unique_lock lock(mu);
        if (stopping) break;
        const std::uint64_t seen = notifications;
        try {
          if (!store) store = std::make_unique<store::Store>(store::Store::open(db));
          id = claim_next(*store);
        } catch (const std::exception& e) {
          spdlog::error("diagnosis worker: cannot read the queue: {}", e.what());
          store.reset();
        }
        if (id.empty()) {
          cv.wait_for(lock, options.poll, [&] { return stopping || notifications != seen; });
          continue;
        }
      }
      run_one(*store, id);
      {
        std::lock_guard lock(mu);
        running.reset();
      }
      finished.fetch_add(1);
    }
    std::lock_guard lock(mu);
    done = true;
    cv.notify_all();
  }
};

DiagnosisWorker::DiagnosisWorker(std::filesystem::path db, DiagnosisWorkerOptions options,
                                 DiagnoseFn fn)
    : shared_(std::make_shared<Shared>()) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("DiagnosisWorkerOptions: " + why);
  if (!fn) throw std::invalid_argument("DiagnosisWorker: no diagnose function");
  shared_->db = std::move(db);
  shared_->options = options;
  shared_->fn = std::move(fn);
}

DiagnosisWorker::~DiagnosisWorker() { shutdown(); }

void DiagnosisWorker::start() {
  std::lock_guard lock(shared_->mu);
  if (thread_.joinable() || shared_->stopping) return;
  thread_ = std::thread([s = shared_] { s->loop(); });
}

bool DiagnosisWorker::shutdown(std::chrono::milliseconds grace) {
  std::optional<std::string> running;
  {
    std::lock_guard lock(shared_->mu);
    shared_->stopping = true;
    running = shared_->running;
    if (running) shared_->stop_running = true;
  }
  shared_->cv.notify_all();
  if (!thread_.joinable()) return true;
  if (running) {
    try {
      auto store = store::Store::open(shared_->db);
      if (store.requeue_diagnosis(*running))
        spdlog::info("diagnosis {}: interrupted by shutdown, re-queued", *running);
    } catch (const std::exception& e) {
      spdlog::error("diagnosis {}: cannot re-queue it: {}", *running, e.what());
    }
  }
  bool done = false;
  {
    std::unique_lock lock(shared_->mu);
    if (grace == std::chrono::milliseconds::max())
      shared_->cv.wait(lock, [&] { return shared_->done; });
    else
      shared_->cv.wait_for(lock, grace, [&] { return shared_->done; });
    done = shared_->done;
  }
  if (done) {
    thread_.join();
    return true;
  }
  thread_.detach();
  return false;
}

void DiagnosisWorker::notify_diagnosis() {
  {
    std::lock_guard lock(shared_->mu);
    ++shared_->notifications;
  }
  shared_->cv.notify_all();
}

CancelOutcome DiagnosisWorker::cancel_diagnosis(store::Store& store, const std::string& id) {
  std::lock_guard lock(shared_->mu);
  // Claimed or not, the store decides: a running diagnosis becomes cancelled now and the
  // worker's finish_diagnosis will not overwrite it. A running one is also asked to stop.
  const CancelOutcome outcome = cancel_diagnosis_unclaimed(store, id);
  if (outcome == CancelOutcome::kCancelled && shared_->running == id) shared_->stop_running = true;
  return outcome;
}

std::optional<std::string> DiagnosisWorker::running() const {
  std::lock_guard lock(shared_->mu);
  return shared_->running;
}

std::size_t DiagnosisWorker::finished() const noexcept { return shared_->finished.load(); }

}  // namespace stickslip::server
