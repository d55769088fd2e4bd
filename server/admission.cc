#include "server/admission.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace weavefit {

UploadLimits::UploadLimits(int max_uploads, std::int64_t max_bytes)
    : max_uploads_(std::max(1, max_uploads)), max_bytes_(std::max<std::int64_t>(1, max_bytes)) {}

absl::Status UploadLimits::Enter(Pass* pass) {
  pass->Reset();
  std::lock_guard<std::mutex> lock(mutex_);
  if (uploads_ >= max_uploads_) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the daemon is receiving ", uploads_, " uploads, its limit (--max-uploads); retry later"));
  }
  ++uploads_;
  *pass = Pass(this);
  pass->uploading_ = true;
  return absl::OkStatus();
}

int UploadLimits::uploads() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return uploads_;
}

std::int64_t UploadLimits::held_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return held_bytes_;
}

UploadLimits::Pass::Pass(Pass&& other) noexcept
    : owner_(other.owner_), held_(other.held_), uploading_(other.uploading_) {
  other.owner_ = nullptr;
  other.held_ = 0;
  other.uploading_ = false;
}

UploadLimits::Pass& UploadLimits::Pass::operator=(Pass&& other) noexcept {
  if (this != &other) {
    Reset();
    owner_ = other.owner_;
    held_ = other.held_;
    uploading_ = other.uploading_;
    other.owner_ = nullptr;
    other.held_ = 0;
    other.uploading_ = false;
  }
  return *this;
}

UploadLimits::Pass::~Pass() { Reset(); }

void UploadLimits::Pass::Reset() {
  if (owner_ == nullptr) return;
  std::lock_guard<std::mutex> lock(owner_->mutex_);
  owner_->held_bytes_ -= held_;
  if (uploading_) --owner_->uploads_;
  owner_ = nullptr;
  held_ = 0;
  uploading_ = false;
}

void UploadLimits::Pass::EndUpload() {
  if (owner_ == nullptr || !uploading_) return;
  std::lock_guard<std::mutex> lock(owner_->mutex_);
  --owner_->uploads_;
  uploading_ = false;
}

absl::Status UploadLimits::Pass::Hold(std::int64_t bytes) {
  if (owner_ == nullptr) return absl::FailedPreconditionError("upload pass not admitted");
  std::lock_guard<std::mutex> lock(owner_->mutex_);
  if (bytes > owner_->max_bytes_ - owner_->held_bytes_) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "the uploads in progress hold %.1f MiB, and this chunk would pass the daemon's limit of "
        "%.1f MiB (--max-upload-memory-mb); retry later",
        owner_->held_bytes_ / 1048576.0, owner_->max_bytes_ / 1048576.0));
  }
  owner_->held_bytes_ += bytes;
  held_ += bytes;
  return absl::OkStatus();
}

void UploadLimits::Pass::Release(std::int64_t bytes) {
  if (owner_ == nullptr) return;
  bytes = std::min(bytes, held_);
  std::lock_guard<std::mutex> lock(owner_->mutex_);
  owner_->held_bytes_ -= bytes;
  held_ -= bytes;
}

Admission::Admission(int max_running, int max_queued, std::int64_t memory_budget)
    : max_running_(std::max(1, max_running)),
      max_queued_(std::max(0, max_queued)),
      memory_budget_(std::max<std::int64_t>(0, memory_budget)) {}

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

std::int64_t Admission::memory_in_use() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return memory_in_use_;
}

Admission::Ticket::Ticket(Ticket&& other) noexcept
    : owner_(other.owner_), running_(other.running_), bytes_(other.bytes_) {
  other.owner_ = nullptr;
  other.running_ = false;
  other.bytes_ = 0;
}

Admission::Ticket& Admission::Ticket::operator=(Ticket&& other) noexcept {
  if (this != &other) {
    Reset();
    owner_ = other.owner_;
    running_ = other.running_;
    bytes_ = other.bytes_;
    other.owner_ = nullptr;
    other.running_ = false;
    other.bytes_ = 0;
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
    owner_->memory_in_use_ -= bytes_;
  }
  running_ = false;
  bytes_ = 0;
  owner_->slot_freed_.notify_all();  // a woken waiter may have given up
}

absl::Status Admission::Ticket::AwaitSlot(std::chrono::steady_clock::time_point deadline,
                                          const std::function<bool()>& cancelled,
                                          std::int64_t bytes, std::chrono::milliseconds poll) {
  if (owner_ == nullptr) return absl::FailedPreconditionError("ticket not admitted");
  if (running_) return absl::OkStatus();
  std::unique_lock<std::mutex> lock(owner_->mutex_);
  const std::int64_t budget = owner_->memory_budget_;
  auto fits = [&] {
    return owner_->running_ < owner_->max_running_ &&
           (budget == 0 || owner_->running_ == 0 || owner_->memory_in_use_ + bytes <= budget);
  };
  while (!fits()) {
    if (cancelled && cancelled()) return absl::CancelledError("client cancelled while queued");
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) {
      return absl::DeadlineExceededError(
          "deadline passed while waiting for a worker and memory to estimate");
    }
    owner_->slot_freed_.wait_until(lock, std::min(deadline, now + poll));
  }
  ++owner_->running_;
  owner_->memory_in_use_ += bytes;
  running_ = true;
  bytes_ = bytes;
  return absl::OkStatus();
}

}  // namespace weavefit
