// Where the engine's parallel loops run. Two backends, chosen when the tree is configured
// (HGRAPH_PARALLEL_BACKEND in the top CMakeLists.txt):
// - oneTBB (the default): the loops run in the calling thread's task arena, which in the server is
//   the worker pool itself;
// - std (HGRAPH_PARALLEL_STD, automatic with HGRAPH_SANITIZE=thread): a process-wide pool of
//   std::threads handed work under a std::mutex. ThreadSanitizer cannot see the synchronization
//   inside Debian's libtbb, which is not instrumented, and reports every hand-off between TBB
//   threads as a race; it sees pthread create, join, mutexes and condition variables, so on this
//   backend a report is about our code.
#pragma once

#include <cstddef>

#ifdef HGRAPH_PARALLEL_STD
#include <algorithm>
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>
#else
#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <utility>
#endif

namespace hgraph {

#ifdef HGRAPH_PARALLEL_STD

namespace parallel_internal {

// Helper threads for ParallelFor: started on first use, as many as the widest loop asked for
// (at most kMaxHelpers), never stopped (detached; they sleep on a condition variable). A loop's
// caller works on its own loop too, so a loop finishes even when every helper is busy elsewhere
// (nested loops, loops of several server jobs at once).
class HelperPool {
 public:
  static constexpr int kMaxHelpers = 256;

  static HelperPool& Get() {
    static HelperPool* pool = new HelperPool();  // never destroyed: helpers may outlive main()
    return *pool;
  }

  // Runs each task on some helper thread, starting helpers until there are at least `wanted`.
  void Post(int wanted, std::vector<std::function<void()>> tasks) {
    std::lock_guard lock(mutex_);
    for (auto& task : tasks) queue_.push_back(std::move(task));
    for (; helpers_ < std::min(wanted, kMaxHelpers); ++helpers_) {
      std::thread([this] { Serve(); }).detach();
    }
    ready_.notify_all();
  }

 private:
  void Serve() {
    std::unique_lock lock(mutex_);
    for (;;) {
      ready_.wait(lock, [this] { return !queue_.empty(); });
      std::function<void()> task = std::move(queue_.front());
      queue_.pop_front();
      lock.unlock();
      task();
      lock.lock();
    }
  }

  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::function<void()>> queue_;
  int helpers_ = 0;
};

// One ParallelFor call, shared by its caller and the helper tasks it posted. A helper that starts
// after the caller has finished the loop (closed) does nothing; the caller returns only when no
// helper is inside the body.
struct Loop {
  explicit Loop(size_t count, std::function<void(size_t)> fn) : n(count), body(std::move(fn)) {}

  // Runs indices until none is left or one has thrown (then the others are skipped, as TBB
  // cancels a loop whose body throws).
  void Work() {
    for (;;) {
      size_t i;
      {
        std::lock_guard lock(mutex);
        if (next >= n || error) return;
        i = next++;
      }
      try {
        body(i);
      } catch (...) {
        std::lock_guard lock(mutex);
        if (!error) error = std::current_exception();
      }
    }
  }

  // A helper's part: enters only while the loop is open.
  void Help() {
    {
      std::lock_guard lock(mutex);
      if (closed) return;
      ++helping;
    }
    Work();
    std::lock_guard lock(mutex);
    if (--helping == 0) done.notify_all();
  }

  const size_t n;
  const std::function<void(size_t)> body;
  std::mutex mutex;
  std::condition_variable done;
  size_t next = 0;
  int helping = 0;
  bool closed = false;
  std::exception_ptr error;
};

}  // namespace parallel_internal

// The threads a loop asked for with threads = 0 (all cores) gets.
inline int DefaultConcurrency() {
  const unsigned cores = std::thread::hardware_concurrency();
  return cores == 0 ? 1 : static_cast<int>(cores);
}

// Calls body(i) once for every i in [0, n), on up to `threads` threads including the caller's;
// returns when every call has returned. If a call throws, the remaining indices may be skipped
// and the first exception is rethrown here. The calls may run concurrently: body must be safe
// to call from several threads at once.
template <class Body>
void ParallelFor(int threads, size_t n, const Body& body) {
  const int helpers =
      static_cast<int>(std::min<size_t>(n, static_cast<size_t>(std::max(threads, 1)))) - 1;
  if (helpers <= 0) {
    for (size_t i = 0; i < n; ++i) body(i);
    return;
  }
  auto loop = std::make_shared<parallel_internal::Loop>(n, [&body](size_t i) { body(i); });
  std::vector<std::function<void()>> tasks(static_cast<size_t>(helpers), [loop] { loop->Help(); });
  parallel_internal::HelperPool::Get().Post(helpers, std::move(tasks));
  loop->Work();
  std::unique_lock lock(loop->mutex);
  loop->closed = true;
  loop->done.wait(lock, [&] { return loop->helping == 0; });
  // The exception leaves the loop, which a helper may be the last to release: its last reference
  // then drops here, in the thread that handles it, and not in a helper still unwinding its task
  // (ThreadSanitizer cannot see libstdc++'s reference count on exceptions).
  std::exception_ptr error = std::exchange(loop->error, nullptr);
  lock.unlock();
  if (error) std::rethrow_exception(std::move(error));
}

#else  // oneTBB

// The threads a loop asked for with threads = 0 (all cores) gets.
inline int DefaultConcurrency() { return tbb::info::default_concurrency(); }

// Runs `body` (which starts TBB parallel work) with `threads` threads: in the calling thread's
// arena when that arena has exactly that concurrency — the default arena in process, or the
// server's worker pool, whose jobs ask for its size — and otherwise in a new arena of that size.
// A nested arena of the same size would only wait for the pool's threads to move into it. The
// body runs isolated: while this thread waits for its loop it runs only the loop's own tasks,
// never another job queued on the same arena.
template <class Body>
void RunWithThreads(int threads, Body&& body) {
  if (tbb::this_task_arena::max_concurrency() == threads) {
    tbb::this_task_arena::isolate(std::forward<Body>(body));
    return;
  }
  tbb::task_arena arena(threads);
  arena.execute(std::forward<Body>(body));
}

// Calls body(i) once for every i in [0, n), on up to `threads` threads including the caller's
// (RunWithThreads); returns when every call has returned. If a call throws, the remaining indices
// may be skipped and the exception is rethrown here. The calls may run concurrently: body must
// be safe to call from several threads at once.
template <class Body>
void ParallelFor(int threads, size_t n, const Body& body) {
  RunWithThreads(threads, [&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1),
                      [&](const tbb::blocked_range<size_t>& range) {
                        for (size_t i = range.begin(); i != range.end(); ++i) body(i);
                      });
  });
}

#endif

// Runs first() and second(), on two threads when `beside` and another thread is free for it,
// else first() and then second() in the calling thread; returns when both have returned, and
// rethrows the first exception either threw. For work split in two halves that watch each
// other's progress (the second finds little left to do once the first has run), so that a
// thread left idle by an uneven loop takes a share of the loop's longest item: inside a
// ParallelFor body, second() is offered to that loop's threads (oneTBB: under its isolation).
template <class First, class Second>
void RunBeside(bool beside, const First& first, const Second& second) {
  if (!beside) {
    first();
    second();
    return;
  }
#ifdef HGRAPH_PARALLEL_STD
  ParallelFor(2, 2, [&](size_t i) {
    if (i == 0) {
      first();
    } else {
      second();
    }
  });
#else
  tbb::task_group group;
  group.run([&second] { second(); });
  try {
    first();
  } catch (...) {
    // second() watches the same stop as first(); its own error, if any, is dropped.
    group.cancel();
    try {
      group.wait();
    } catch (...) {
    }
    throw;
  }
  group.wait();
#endif
}

}  // namespace hgraph
