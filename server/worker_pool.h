// A fixed pool of threads that run the daemon's estimates: the gRPC callback
// threads only read uploads and hand complete ones over here, so that a
// slow client never holds a thread that could estimate, and an estimate
// never blocks gRPC's own threads. How many jobs wait is bounded by the
// caller (Admission), not here.
#ifndef WEAVEFIT_SERVER_WORKER_POOL_H_
#define WEAVEFIT_SERVER_WORKER_POOL_H_

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace weavefit {

class WorkerPool {
 public:
  explicit WorkerPool(int threads);
  // Runs the jobs already scheduled, then joins the threads.
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Runs `job` on a pool thread, in the order scheduled.
  void Schedule(std::function<void()> job);

 private:
  void Run();
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> jobs_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_WORKER_POOL_H_
