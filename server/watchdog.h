// Cancels calls whose server-side deadline passes while they are blocked in
// a read (a client that stalls mid-upload without a deadline of its own would
// otherwise hold its admission forever). One thread for all calls.
#ifndef WEAVEFIT_SERVER_WATCHDOG_H_
#define WEAVEFIT_SERVER_WATCHDOG_H_

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <thread>

namespace weavefit {

class Watchdog {
 public:
  using Clock = std::chrono::steady_clock;
  Watchdog();
  ~Watchdog();

  // Calls `expire` once at `deadline` unless the guard is destroyed first.
  class Guard {
   public:
    Guard(Watchdog* owner, Clock::time_point deadline, std::function<void()> expire);
    ~Guard();
    Guard(const Guard&) = delete;
    Guard& operator=(const Guard&) = delete;
    // True once `expire` has run.
    bool expired() const { return expired_.load(); }
    // Moves the deadline (an upload's idle limit after each message); no
    // effect once expired.
    void MoveTo(Clock::time_point deadline);

   private:
    friend class Watchdog;
    Watchdog* owner_;
    std::multimap<Clock::time_point, Guard*>::iterator entry_;
    std::function<void()> expire_;
    std::atomic<bool> expired_{false};
  };

 private:
  void Run();
  std::mutex mutex_;
  std::condition_variable changed_;
  std::multimap<Clock::time_point, Guard*> pending_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_WATCHDOG_H_
