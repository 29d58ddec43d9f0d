#include "server/worker_pool.h"

#include <utility>

#include "core/common/error.h"

#ifdef HGRAPH_PARALLEL_STD
#include <deque>
#include <thread>
#include <vector>
#else
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#endif

namespace hgraph::server {

#ifdef HGRAPH_PARALLEL_STD

// N std::threads serving one queue; the destructor lets them finish what is queued.
class WorkerPool::Runner {
 public:
  explicit Runner(int threads) {
    for (int i = 0; i < threads; ++i) workers_.emplace_back([this] { Serve(); });
  }
  ~Runner() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    ready_.notify_all();
    for (std::thread& worker : workers_) worker.join();
  }

  void Run(std::function<void()> task) {
    {
      std::lock_guard lock(mutex_);
      queue_.push_back(std::move(task));
    }
    ready_.notify_one();
  }

 private:
  void Serve() {
    std::unique_lock lock(mutex_);
    for (;;) {
      ready_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;
      std::function<void()> task = std::move(queue_.front());
      queue_.pop_front();
      lock.unlock();
      task();
      task = nullptr;
      lock.lock();
    }
  }

  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::function<void()>> queue_;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

#else

class WorkerPool::Runner {
 public:
  // Enqueued jobs are run by TBB worker threads only (no thread joins the arena), so the
  // global limit is threads + 1: TBB counts one slot for an external thread.
  explicit Runner(int threads)
      : parallelism_(tbb::global_control::max_allowed_parallelism,
                     static_cast<size_t>(threads) + 1),
        arena_(threads, /*reserved_for_masters=*/0) {
    arena_.initialize();
  }

  void Run(std::function<void()> task) { arena_.enqueue(std::move(task)); }

 private:
  tbb::global_control parallelism_;
  tbb::task_arena arena_;
};

#endif

WorkerPool::WorkerPool(int threads, int max_admitted)
    : threads_(threads), max_admitted_(max_admitted) {
  HGRAPH_CHECK(threads >= 1 && max_admitted >= 1);
  runner_ = std::make_unique<Runner>(threads);
}

WorkerPool::~WorkerPool() { WaitIdle(); }

void WorkerPool::Slot::Release() {
  if (released_) return;
  released_ = true;
  pool_->admitted_.fetch_sub(1);
}

bool WorkerPool::TryHold() {
  int current = admitted_.load();
  do {
    if (current >= max_admitted_) return false;
  } while (!admitted_.compare_exchange_weak(current, current + 1));
  return true;
}

void WorkerPool::Unhold() { admitted_.fetch_sub(1); }

bool WorkerPool::TrySubmit(std::function<void(Slot&)> job) {
  if (!TryHold()) return false;
  SubmitHeld(std::move(job));
  return true;
}

void WorkerPool::SubmitHeld(std::function<void(Slot&)> job) {
  running_.fetch_add(1);
  runner_->Run([this, job = std::move(job)] {
    Slot slot(this);
    job(slot);
    slot.Release();
    if (running_.fetch_sub(1) == 1) {
      std::lock_guard lock(mutex_);
      idle_.notify_all();
    }
  });
}

bool WorkerPool::TryRunOnIdleWorker(std::function<void()> job) {
  // running_ counts the jobs queued or running: fewer than the workers means one is idle.
  int current = running_.load();
  do {
    if (current >= threads_) return false;
  } while (!running_.compare_exchange_weak(current, current + 1));
  if (!TryHold()) {
    if (running_.fetch_sub(1) == 1) {
      std::lock_guard lock(mutex_);
      idle_.notify_all();
    }
    return false;
  }
  runner_->Run([this, job = std::move(job)] {
    Slot slot(this);
    job();
    slot.Release();
    if (running_.fetch_sub(1) == 1) {
      std::lock_guard lock(mutex_);
      idle_.notify_all();
    }
  });
  return true;
}

void WorkerPool::WaitIdle() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [this] { return running_.load() == 0; });
}

}  // namespace hgraph::server
