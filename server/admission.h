// Admission control for weavefitd, in two stages that guard different
// resources.
//
// Uploads (UploadLimits): a call holds an upload pass from its first
// message until its bytes are decoded. At most `max_uploads` passes exist at
// once and together they hold at most `max_bytes` of received image bytes;
// beyond either, RESOURCE_EXHAUSTED. A slow or stalled upload therefore
// costs one pass and its bytes, never an estimation slot.
//
// Estimates (Admission): a call enters only once its upload is complete. At
// most `max_running` estimates run at once, their working memory together
// within `memory_budget` bytes, and at most `max_queued` more wait; a call
// beyond both is refused at once with RESOURCE_EXHAUSTED.
#ifndef WEAVEFIT_SERVER_ADMISSION_H_
#define WEAVEFIT_SERVER_ADMISSION_H_

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>

#include "absl/status/status.h"

namespace weavefit {

class UploadLimits {
 public:
  UploadLimits(int max_uploads, std::int64_t max_bytes);

  // One upload in progress. Destroying it gives back its place and bytes.
  class Pass {
   public:
    Pass() = default;
    Pass(Pass&& other) noexcept;
    Pass& operator=(Pass&& other) noexcept;
    ~Pass();
    bool admitted() const { return owner_ != nullptr; }
    // Counts `bytes` more as held; RESOURCE_EXHAUSTED (nothing counted) when
    // that would pass the limit of all uploads together.
    absl::Status Hold(std::int64_t bytes);
    // Gives back `bytes` of those held (the upload's bytes were decoded).
    void Release(std::int64_t bytes);
    // The upload is complete: its place is given back, its bytes stay held
    // until released.
    void EndUpload();
    std::int64_t held() const { return held_; }

   private:
    friend class UploadLimits;
    explicit Pass(UploadLimits* owner) : owner_(owner) {}
    void Reset();
    UploadLimits* owner_ = nullptr;
    std::int64_t held_ = 0;
    bool uploading_ = false;
  };

  // A pass, or RESOURCE_EXHAUSTED when `max_uploads` are in progress.
  absl::Status Enter(Pass* pass);

  int uploads() const;
  std::int64_t held_bytes() const;

 private:
  const int max_uploads_;
  const std::int64_t max_bytes_;
  mutable std::mutex mutex_;
  int uploads_ = 0;
  std::int64_t held_bytes_ = 0;
};

class Admission {
 public:
  // memory_budget <= 0: no memory budget.
  Admission(int max_running, int max_queued, std::int64_t memory_budget = 0);

  // One admitted call. Destroying it gives back its worker slot and memory
  // (if it holds them) and its place.
  class Ticket {
   public:
    Ticket() = default;
    Ticket(Ticket&& other) noexcept;
    Ticket& operator=(Ticket&& other) noexcept;
    ~Ticket();

    bool admitted() const { return owner_ != nullptr; }
    // Waits until `deadline` for a worker slot and `bytes` of the memory
    // budget (all of it is granted to a call that runs alone, so a call
    // within the budget never starves), asking `cancelled` every `poll`
    // meanwhile. DEADLINE_EXCEEDED or CANCELLED when it gives up.
    absl::Status AwaitSlot(std::chrono::steady_clock::time_point deadline,
                           const std::function<bool()>& cancelled, std::int64_t bytes = 0,
                           std::chrono::milliseconds poll = std::chrono::milliseconds(20));
    // Gives the worker slot and memory back early (the call stays admitted).
    void ReleaseSlot();

   private:
    friend class Admission;
    explicit Ticket(Admission* owner) : owner_(owner) {}
    void Reset();
    Admission* owner_ = nullptr;
    bool running_ = false;
    std::int64_t bytes_ = 0;
  };

  // A ticket, or RESOURCE_EXHAUSTED when running + queued is at the limit.
  absl::Status Enter(Ticket* ticket);

  int running() const;
  // Admitted calls not holding a worker slot (waiting for one).
  int queued() const;
  // Working memory of the running estimates, bytes.
  std::int64_t memory_in_use() const;
  int max_running() const { return max_running_; }
  int max_queued() const { return max_queued_; }
  std::int64_t memory_budget() const { return memory_budget_; }

 private:
  const int max_running_;
  const int max_queued_;
  const std::int64_t memory_budget_;
  mutable std::mutex mutex_;
  std::condition_variable slot_freed_;
  int admitted_ = 0;
  int running_ = 0;
  std::int64_t memory_in_use_ = 0;
};

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_ADMISSION_H_
