// Where the engine's parallel loops run.
#pragma once

#include <tbb/task_arena.h>

#include <utility>

namespace hgraph {

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

}  // namespace hgraph
