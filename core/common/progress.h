// Progress reporting and cooperative cancellation for long operations.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "core/common/error.h"

namespace hgraph {

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
  bool cancelled() const { return state_->cancelled.load(std::memory_order_relaxed); }
  bool deadline_passed() const {
    const auto ns = state_->deadline_ns.load(std::memory_order_relaxed);
    return ns != 0 && std::chrono::steady_clock::now().time_since_epoch().count() >= ns;
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
  // Phase "optimize": the objective of the best path so far, after each improvement (NaN in
  // every other phase).
  double objective = std::numeric_limits<double>::quiet_NaN();
};

// Called from worker threads, possibly concurrently; must be thread safe and cheap.
using ProgressCallback = std::function<void(const Progress&)>;

}  // namespace hgraph
