#include "server/worker_pool.h"

#include <utility>

#include "core/common/error.h"

namespace hgraph::server {

WorkerPool::WorkerPool(int threads, int max_admitted)
    : threads_(threads),
      max_admitted_(max_admitted),
      parallelism_(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads) + 1),
      arena_(threads, /*reserved_for_masters=*/0) {
  HGRAPH_CHECK(threads >= 1 && max_admitted >= 1);
  arena_.initialize();
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
  arena_.enqueue([this, job = std::move(job)] {
    Slot slot(this);
    job(slot);
    slot.Release();
    if (running_.fetch_sub(1) == 1) {
      std::lock_guard lock(mutex_);
      idle_.notify_all();
    }
  });
}

void WorkerPool::WaitIdle() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [this] { return running_.load() == 0; });
}

}  // namespace hgraph::server
