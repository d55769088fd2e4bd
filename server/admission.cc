#include "server/admission.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace weavefit {

Admission::Admission(int max_running, int max_queued)
    : max_running_(std::max(1, max_running)), max_queued_(std::max(0, max_queued)) {}

absl::Status Admission::Enter(Ticket* ticket) {
  ticket->Reset();
  std::lock_guard<std::mutex> lock(mutex_);
  if (admitted_ >= max_running_ + max_queued_) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the daemon is at its limit of ", max_running_, " running and ", max_queued_,
        " queued estimates; retry later (weavefitd --max-concurrent, --max-queue)"));
  }
  ++admitted_;
  *ticket = Ticket(this);
  return absl::OkStatus();
}

int Admission::running() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return running_;
}

int Admission::queued() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return admitted_ - running_;
}

Admission::Ticket::Ticket(Ticket&& other) noexcept
    : owner_(other.owner_), running_(other.running_) {
  other.owner_ = nullptr;
  other.running_ = false;
}

Admission::Ticket& Admission::Ticket::operator=(Ticket&& other) noexcept {
  if (this != &other) {
    Reset();
    owner_ = other.owner_;
    running_ = other.running_;
    other.owner_ = nullptr;
    other.running_ = false;
  }
  return *this;
}

Admission::Ticket::~Ticket() { Reset(); }

void Admission::Ticket::Reset() {
  if (owner_ == nullptr) return;
  ReleaseSlot();
  {
    std::lock_guard<std::mutex> lock(owner_->mutex_);
    --owner_->admitted_;
  }
  owner_ = nullptr;
}

void Admission::Ticket::ReleaseSlot() {
  if (owner_ == nullptr || !running_) return;
  {
    std::lock_guard<std::mutex> lock(owner_->mutex_);
    --owner_->running_;
  }
  running_ = false;
  owner_->slot_freed_.notify_all();  // a woken waiter may have given up
}

absl::Status Admission::Ticket::AwaitSlot(std::chrono::steady_clock::time_point deadline,
                                          const std::function<bool()>& cancelled,
                                          std::chrono::milliseconds poll) {
  if (owner_ == nullptr) return absl::FailedPreconditionError("ticket not admitted");
  if (running_) return absl::OkStatus();
  std::unique_lock<std::mutex> lock(owner_->mutex_);
  while (owner_->running_ >= owner_->max_running_) {
    if (cancelled && cancelled()) return absl::CancelledError("client cancelled while queued");
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) {
      return absl::DeadlineExceededError("deadline passed while waiting for a worker");
    }
    owner_->slot_freed_.wait_until(lock, std::min(deadline, now + poll));
  }
  ++owner_->running_;
  running_ = true;
  return absl::OkStatus();
}

}  // namespace weavefit
