#pragma once
// What the HTTP handlers need from the study worker: a wake-up when a study is queued, and
// cancellation that is consistent with the worker picking studies up (see worker.h).

#include <string>

#include "stickslip/store/store.h"

namespace stickslip::server {

enum class CancelOutcome {
  kNotFound,         ///< no such study
  kCancelled,        ///< it was waiting (queued, or running with no worker on it): now cancelled
  kRequested,        ///< a worker runs it: no new run starts; it becomes cancelled shortly
  kAlreadyFinished,  ///< succeeded, failed or cancelled before: unchanged
};

class Scheduler {
 public:
  virtual ~Scheduler() = default;
  /// A study was queued: look at the store now rather than at the next poll.
  virtual void notify() = 0;
  /// Cancels a study; store is the calling thread's own connection.
  virtual CancelOutcome cancel(store::Store& store, const std::string& id) = 0;
};

/// Cancellation of a study that no worker is running: queued or running -> cancelled (its
/// finished runs are kept); a terminal study is left unchanged.
CancelOutcome cancel_unclaimed(store::Store& store, const std::string& id);

}  // namespace stickslip::server
