#include "server/watchdog.h"

namespace weavefit {

Watchdog::Watchdog() : thread_([this] { Run(); }) {}

Watchdog::~Watchdog() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

Watchdog::Guard::Guard(Watchdog* owner, Clock::time_point deadline,
                       std::function<void()> expire)
    : owner_(owner), expire_(std::move(expire)) {
  std::lock_guard<std::mutex> lock(owner_->mutex_);
  entry_ = owner_->pending_.emplace(deadline, this);
  owner_->changed_.notify_all();
}

Watchdog::Guard::~Guard() {
  // Holding the lock while erasing also waits for an `expire` in progress
  // (Run calls it under the lock), so it never runs on a destroyed guard.
  std::lock_guard<std::mutex> lock(owner_->mutex_);
  if (!expired_.load()) owner_->pending_.erase(entry_);
}

void Watchdog::Guard::MoveTo(Clock::time_point deadline) {
  std::lock_guard<std::mutex> lock(owner_->mutex_);
  if (expired_.load()) return;
  owner_->pending_.erase(entry_);
  entry_ = owner_->pending_.emplace(deadline, this);
  owner_->changed_.notify_all();
}

void Watchdog::Run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    if (pending_.empty()) {
      changed_.wait(lock);
      continue;
    }
    auto first = pending_.begin();
    // A copy: wait_until keeps reading its deadline while the lock is
    // released, and a guard may erase the map node meanwhile (found by
    // request_fuzzer under AddressSanitizer).
    const Clock::time_point next = first->first;
    if (Clock::now() < next) {
      changed_.wait_until(lock, next);
      continue;
    }
    Guard* guard = first->second;
    pending_.erase(first);
    guard->expired_ = true;
    guard->expire_();  // grpc::ServerContext::TryCancel: quick, thread-safe
  }
}

}  // namespace weavefit
