#include "stickslip/server/store_pool.h"

namespace stickslip::server {

StorePool::StorePool(std::filesystem::path db, std::size_t max_idle)
    : db_(std::move(db)), max_idle_(max_idle) {
  idle_.push_back(std::make_unique<store::Store>(store::Store::open(db_)));
}

StorePool::Lease::~Lease() {
  if (pool_ != nullptr && store_ != nullptr) pool_->release(std::move(store_));
}

StorePool::Lease StorePool::acquire() {
  {
    std::lock_guard lock(mu_);
    if (!idle_.empty()) {
      auto store = std::move(idle_.back());
      idle_.pop_back();
      return Lease(this, std::move(store));
    }
  }
  return Lease(this, std::make_unique<store::Store>(store::Store::open(db_)));
}

void StorePool::release(std::unique_ptr<store::Store> store) {
  std::lock_guard lock(mu_);
  if (idle_.size() < max_idle_) idle_.push_back(std::move(store));
}

}  // namespace stickslip::server
