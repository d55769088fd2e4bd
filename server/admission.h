// Admission control for weavefitd: at most `max_running` estimates at once and
// at most `max_queued` more admitted and waiting (each holding its upload in
// memory). A call beyond both is refused at once with RESOURCE_EXHAUSTED, so
// memory stays bounded by (max_running + max_queued) calls' uploads (each at
// most ServiceOptions::max_call_bytes) whatever the load.
#ifndef WEAVEFIT_SERVER_ADMISSION_H_
#define WEAVEFIT_SERVER_ADMISSION_H_

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>

#include "absl/status/status.h"

namespace weavefit {

class Admission {
 public:
  Admission(int max_running, int max_queued);

  // One admitted call. Destroying it gives back its worker slot (if it holds
  // one) and its place.
  class Ticket {
   public:
    Ticket() = default;
    Ticket(Ticket&& other) noexcept;
    Ticket& operator=(Ticket&& other) noexcept;
    ~Ticket();

    bool admitted() const { return owner_ != nullptr; }
    // Waits for a worker slot until `deadline`, asking `cancelled` every
    // `poll` meanwhile. DEADLINE_EXCEEDED or CANCELLED when it gives up.
    absl::Status AwaitSlot(std::chrono::steady_clock::time_point deadline,
                           const std::function<bool()>& cancelled,
                           std::chrono::milliseconds poll = std::chrono::milliseconds(20));
    // Gives the worker slot back early (the call stays admitted).
    void ReleaseSlot();

   private:
    friend class Admission;
    explicit Ticket(Admission* owner) : owner_(owner) {}
    void Reset();
    Admission* owner_ = nullptr;
    bool running_ = false;
  };

  // A ticket, or RESOURCE_EXHAUSTED when running + queued is at the limit.
  absl::Status Enter(Ticket* ticket);

  int running() const;
  // Admitted calls not holding a worker slot (reading their upload or waiting).
  int queued() const;
  int max_running() const { return max_running_; }
  int max_queued() const { return max_queued_; }

 private:
  const int max_running_;
  const int max_queued_;
  mutable std::mutex mutex_;
  std::condition_variable slot_freed_;
  int admitted_ = 0;
  int running_ = 0;
};

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_ADMISSION_H_
