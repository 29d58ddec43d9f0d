// Progress reporting and cooperative cancellation for long operations.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "core/common/error.h"

namespace hgraph {

struct InputPath;  // core/path/path.h

// Milliseconds of wall time since `start` (the per-phase timings of merges and checks).
inline double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// A flag that any thread may set and that long operations poll. Thread safe. Shared by
// copying the token: all copies observe the same flag. An optional deadline makes
// ThrowIfStopped report kDeadlineExceeded once it has passed.
class CancelToken {
 public:
  CancelToken() : state_(std::make_shared<State>()) {}

  void Cancel() const { state_->cancelled.store(true, std::memory_order_relaxed); }
  void SetDeadline(std::chrono::steady_clock::time_point deadline) const {
    state_->deadline_ns.store(deadline.time_since_epoch().count(), std::memory_order_relaxed);
  }
  // A token that stops when this one does, and also at `deadline`: a budget inside the caller's
  // work. Stopping or cancelling it leaves this one as it is.
  CancelToken WithDeadline(std::chrono::steady_clock::time_point deadline) const {
    CancelToken child;
    child.state_->parent = state_;
    child.SetDeadline(deadline);
    return child;
  }
  bool cancelled() const {
    for (const State* s = state_.get(); s != nullptr; s = s->parent.get()) {
      if (s->cancelled.load(std::memory_order_relaxed)) return true;
    }
    return false;
  }
  bool deadline_passed() const {
    const int64_t now = std::chrono::steady_clock::now().time_since_epoch().count();
    for (const State* s = state_.get(); s != nullptr; s = s->parent.get()) {
      const auto ns = s->deadline_ns.load(std::memory_order_relaxed);
      if (ns != 0 && now >= ns) return true;
    }
    return false;
  }
  bool stopped() const { return cancelled() || deadline_passed(); }
  // Throws Error(kCancelled) or Error(kDeadlineExceeded) if the work should stop.
  void ThrowIfStopped() const {
    if (cancelled()) throw Error(ErrorCode::kCancelled, "", "cancelled by the caller");
    if (deadline_passed()) throw Error(ErrorCode::kDeadlineExceeded, "", "deadline exceeded");
  }

 private:
  struct State {
    std::atomic<bool> cancelled{false};
    std::atomic<int64_t> deadline_ns{0};
    std::shared_ptr<const State> parent;  // WithDeadline's token
  };
  std::shared_ptr<State> state_;
};

// One progress report. `done` of `total` units of the current phase are finished.
struct Progress {
  std::string phase;  // "validate", "inputs", "align", "candidates", "check", "search", "evaluate"
  int64_t done = 0;
  int64_t total = 0;
  int64_t collision_checks = 0;
  int64_t distance_queries = 0;
  double elapsed_ms = 0;
  // Phase "optimize": the objective of the best path so far, first the H-Graph optimum's (round
  // 0), then after each improvement (NaN in every other phase).
  double objective = std::numeric_limits<double>::quiet_NaN();
  // Phase "optimize", when asked for (MergeOptions::progress_paths): the path of `objective`,
  // every motion of it proven free, so that a caller who stops the merge keeps the best so far.
  std::shared_ptr<const InputPath> path;
};

// Called from worker threads, possibly concurrently; must be thread safe and cheap.
using ProgressCallback = std::function<void(const Progress&)>;

// The progress of `total` units of work done in parallel (the edge checks of a merge or of
// CheckPaths), reported at most about once per percent of the work and always at the last unit,
// so that many small units do not flood the stream. Thread safe as far as the callback is; holds
// a reference to the callback, which must outlive it.
class ThrottledProgress {
 public:
  ThrottledProgress(const ProgressCallback& callback, std::string phase, int64_t total,
                    std::chrono::steady_clock::time_point started)
      : callback_(callback),
        phase_(std::move(phase)),
        total_(total),
        step_(std::max<int64_t>(1, total / 100)),
        started_(started) {}

  // Unit `done` (counted from 1) has finished, with the checks and queries done so far in this
  // phase; reports it when it falls on the step.
  void Done(int64_t done, int64_t collision_checks, int64_t distance_queries) const {
    if (!callback_ || (done % step_ != 0 && done != total_)) return;
    callback_(Progress{.phase = phase_,
                       .done = done,
                       .total = total_,
                       .collision_checks = collision_checks,
                       .distance_queries = distance_queries,
                       .elapsed_ms = MsSince(started_)});
  }

 private:
  const ProgressCallback& callback_;
  std::string phase_;
  int64_t total_;
  int64_t step_;
  std::chrono::steady_clock::time_point started_;
};

}  // namespace hgraph
