#pragma once
// A pool of Store connections for the HTTP handler threads. A connection is leased by one thread
// at a time and returned to the pool afterwards, so no connection is ever used by two threads at
// once (store.h's threading contract) while handlers still avoid opening SQLite for every request.

#include <cstddef>
#include <filesystem>
#include <memory>
#include <mutex>
#include <vector>

#include "stickslip/store/store.h"

namespace stickslip::server {

class StorePool {
 public:
  /// Opens (creating or initialising) the database once, so that a bad path fails here with
  /// StoreError, not on the first request. Keeps up to max_idle connections for reuse.
  explicit StorePool(std::filesystem::path db, std::size_t max_idle = 8);

  class Lease {
   public:
    Lease(StorePool* pool, std::unique_ptr<store::Store> store)
        : pool_(pool), store_(std::move(store)) {}
    Lease(Lease&&) noexcept = default;
    Lease& operator=(Lease&&) = delete;
    ~Lease();
    store::Store& operator*() const noexcept { return *store_; }
    store::Store* operator->() const noexcept { return store_.get(); }

   private:
    StorePool* pool_;
    std::unique_ptr<store::Store> store_;
  };

  /// A connection for the calling thread; opens a new one when none is idle.
  Lease acquire();
  const std::filesystem::path& path() const noexcept { return db_; }

 private:
  void release(std::unique_ptr<store::Store> store);
  std::filesystem::path db_;
  std::size_t max_idle_;
  std::mutex mu_;
  std::vector<std::unique_ptr<store::Store>> idle_;
};

}  // namespace stickslip::server
