#include "server/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>

namespace hgraph::server {
namespace {

// A latch the jobs wait on, so that the test decides when they end (no sleeps).
struct Gate {
  std::mutex mutex;
  std::condition_variable changed;
  bool open = false;
  int waiting = 0;
  void Wait() {
    std::unique_lock lock(mutex);
    ++waiting;
    changed.notify_all();
    changed.wait(lock, [this] { return open; });
  }
  bool WaitForWaiting(int n) {
    std::unique_lock lock(mutex);
    return changed.wait_for(lock, std::chrono::seconds(60), [&] { return waiting >= n; });
  }
  void Open() {
    std::lock_guard lock(mutex);
    open = true;
    changed.notify_all();
  }
};

TEST(WorkerPool, AdmitsUpToItsLimitThenRefuses) {
  WorkerPool pool(2, 2);
  Gate gate;
  std::atomic<int> ran{0};
  ASSERT_TRUE(pool.TrySubmit([&](WorkerPool::Slot&) {
    gate.Wait();
    ++ran;
  }));
  ASSERT_TRUE(pool.TrySubmit([&](WorkerPool::Slot&) {
    gate.Wait();
    ++ran;
  }));
  ASSERT_TRUE(gate.WaitForWaiting(2));
  EXPECT_EQ(pool.admitted(), 2);
  EXPECT_FALSE(pool.TrySubmit([&](WorkerPool::Slot&) { ++ran; }));
  gate.Open();
  pool.WaitIdle();
  EXPECT_EQ(ran.load(), 2);
  EXPECT_EQ(pool.admitted(), 0);
}

// A job beside a call's runs only on an idle worker with a free admission slot, and holds the
// slot while it runs: never queued behind other jobs.
TEST(WorkerPool, RunsOnAnIdleWorkerOnlyAndHoldsASlotWhileItRuns) {
  std::atomic<int> ran{0};
  {
    WorkerPool pool(2, 3);
    Gate gate;
    ASSERT_TRUE(pool.TrySubmit([&](WorkerPool::Slot&) {
      gate.Wait();
      ++ran;
    }));
    // One worker is idle: the job beside starts there and takes a second slot.
    ASSERT_TRUE(pool.TryRunOnIdleWorker([&] {
      gate.Wait();
      ++ran;
    }));
    ASSERT_TRUE(gate.WaitForWaiting(2));
    EXPECT_EQ(pool.admitted(), 2);
    // Both workers busy: refused although an admission slot is free, and not run later.
    EXPECT_FALSE(pool.TryRunOnIdleWorker([&] { ran += 100; }));
    EXPECT_EQ(pool.admitted(), 2);
    // A call still queues for a busy pool (its admission is separate).
    ASSERT_TRUE(pool.TrySubmit([&](WorkerPool::Slot&) { ++ran; }));
    EXPECT_EQ(pool.admitted(), 3);
    gate.Open();
    pool.WaitIdle();
    EXPECT_EQ(ran.load(), 3);
    EXPECT_EQ(pool.admitted(), 0);
  }
  // Idle workers but no free admission slot: refused.
  WorkerPool pool(2, 1);
  Gate gate;
  ASSERT_TRUE(pool.TrySubmit([&](WorkerPool::Slot&) { gate.Wait(); }));
  ASSERT_TRUE(gate.WaitForWaiting(1));
  EXPECT_FALSE(pool.TryRunOnIdleWorker([&] { ran += 100; }));
  gate.Open();
  pool.WaitIdle();
  EXPECT_EQ(ran.load(), 3);
}

// A job that releases its slot before its last steps lets the next call in at once.
TEST(WorkerPool, AReleasedSlotAdmitsTheNextJobWhileTheFirstStillRuns) {
  WorkerPool pool(2, 1);
  Gate gate;
  std::atomic<bool> second_ran{false};
  ASSERT_TRUE(pool.TrySubmit([&](WorkerPool::Slot& slot) {
    slot.Release();
    slot.Release();  // idempotent
    gate.Wait();
  }));
  ASSERT_TRUE(gate.WaitForWaiting(1));
  EXPECT_EQ(pool.admitted(), 0);
  EXPECT_TRUE(pool.TrySubmit([&](WorkerPool::Slot&) { second_ran = true; }));
  gate.Open();
  pool.WaitIdle();
  EXPECT_TRUE(second_ran.load());
}

TEST(WorkerPool, QueuedJobsBeyondTheThreadsAllRun) {
  WorkerPool pool(1, 16);
  std::atomic<int> ran{0};
  for (int i = 0; i < 16; ++i) {
    ASSERT_TRUE(pool.TrySubmit([&](WorkerPool::Slot&) { ++ran; }));
  }
  pool.WaitIdle();
  EXPECT_EQ(ran.load(), 16);
  EXPECT_EQ(pool.threads(), 1);
  EXPECT_EQ(pool.max_admitted(), 16);
}

}  // namespace
}  // namespace hgraph::server
