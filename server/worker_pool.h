// The server's worker pool: every CPU-bound step of a call (hashing uploads, loading scenes,
// building and searching H-Graphs) runs here, never on a gRPC thread. A oneTBB task_arena of
// N threads runs the jobs; the engine's own parallel loops nest inside them, and a process-wide
// tbb::global_control keeps the total at N threads however many jobs run at once. In builds with
// the std parallel backend (core/common/parallel.h; ThreadSanitizer builds) N std::threads run
// the jobs instead, and the engine's loops take helper threads of their own.
#pragma once

#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>

namespace hgraph::server {

// Thread safe. Not copyable or movable. One per process (it sets TBB's global parallelism).
class WorkerPool {
 public:
  // threads >= 1; max_admitted >= 1 jobs may be queued or running at once.
  WorkerPool(int threads, int max_admitted);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // A job's hold on its admission slot. The job calls Release() (idempotent) just before it
  // sends its call's final message: a client that starts its next call the moment it has an
  // answer must find the slot free, not still held by the job's last few instructions. The pool
  // releases the slot after the job returns in any case.
  class Slot {
   public:
    void Release();

   private:
    friend class WorkerPool;
    explicit Slot(WorkerPool* pool) : pool_(pool) {}
    WorkerPool* pool_;
    bool released_ = false;
  };

  // Queues the job, or returns false without running it when the admission queue is full (the
  // caller answers RESOURCE_EXHAUSTED). The job must not throw.
  bool TrySubmit(std::function<void(Slot&)> job);
  // An admission slot held without a job yet (an upload waiting for its chunks): it counts
  // against max_admitted like a job's. Returns false when the queue is full.
  bool TryHold();
  void Unhold();
  // Queues a job on a slot taken with TryHold; the job's Slot releases it.
  void SubmitHeld(std::function<void(Slot&)> job);
  // Starts `job` now on a worker that has nothing else to run, holding an admission slot while
  // it runs (a Solve's planner run beside the Solve's own job), or returns false without
  // running it when every worker has a job or the admission queue is full: the job never waits
  // in the queue behind other calls. The job must not throw.
  bool TryRunOnIdleWorker(std::function<void()> job);
  // Blocks until every admitted job has returned.
  void WaitIdle();

  int threads() const { return threads_; }
  int max_admitted() const { return max_admitted_; }
  int admitted() const { return admitted_.load(); }

 private:
  class Runner;  // the threads that run the jobs (worker_pool.cc: oneTBB or std::thread)

  const int threads_;
  const int max_admitted_;
  std::atomic<int> admitted_{0};  // jobs holding an admission slot
  std::atomic<int> running_{0};   // jobs queued or running, whether or not they hold a slot
  std::mutex mutex_;
  std::condition_variable idle_;
  std::unique_ptr<Runner> runner_;  // last: its threads stop before the members above go
};

}  // namespace hgraph::server
