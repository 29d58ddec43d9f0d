// Solve: the best certified path within a time budget, from a portfolio of planners whose paths
// are merged into one H-Graph as they arrive ("a little more, a lot better" as one call).
//
// Planners (core/plan) run as tasks started by SolveRequest::start_beside (in the server, jobs on
// its worker pool while the pool has a free worker; in process, threads of their own), as many at
// once as SolveRequest::parallel says and the pool allows; the calling thread plans too while no
// task could start and no path waits to be merged. It adds each path to the H-Graph as it
// arrives (the AddPaths code path of HybridizationSession), searches it again and reports the
// best certified path so far. When every planner has stopped (at the latest when the planning
// share of the budget ends), the last query's post-optimization runs until the budget's end.
// The H-Graph is returned for re-queries and additions, as a merge's.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/common/progress.h"
#include "core/merge/merge.h"
#include "core/motion/motion_checker.h"
#include "core/path/path.h"
#include "core/plan/plan.h"

namespace hgraph {

// One kind of planner in a portfolio and how many runs of it (each with its own seed).
struct PortfolioEntry {
  PlannerType planner = PlannerType::kPRM;
  int runs = 1;
};

// The portfolio used when the request names none, for `parallel` runs at once and a budget of
// `budget_s`: below kLongSolveBudgetS one RRT* run and PRM runs (the paper's, without cycles) in
// the other slots, two per slot in all (the RRT* run starts first and keeps its slot for the
// planning time: RunOrder in solve.cc); with one slot, two PRM runs. From kLongSolveBudgetS on,
// one PRM run per slot (at least two) and BIT* and RRT* runs (one each per two slots, at least
// one each), which start when the PRM runs have and share the planning time those leave. PRM's
// runs end at their first path, and their paths may all take a poor route that no merge can
// leave (the bench's `flat`), where an optimizing planner given the rest of the time finds
// another. Measured on the bench's real-size problems (docs/performance.md, "Solve").
inline constexpr double kLongSolveBudgetS = 10;
std::vector<PortfolioEntry> DefaultPortfolio(int parallel = 2, double budget_s = 3);
// The default share of the budget given to planning (SolveRequest::plan_fraction) once a query
// has certified a path; while none has, the planners go on until one has.
inline constexpr double kDefaultPlanFraction = 0.7;
// Limits of a request (range-checked, errors naming the field).
inline constexpr double kMinSolveBudgetS = 0.01;
inline constexpr double kMaxSolveBudgetS = 3600;
inline constexpr int kMaxSolveRuns = 64;

// One planner run of a Solve.
struct SolveRun {
  PlannerType planner = PlannerType::kPRM;
  int index = 0;        // in the order the runs started, from 0
  uint64_t seed = 0;    // the seed OMPL got (PlanAttemptSeed of the run's seed)
  double time_s = 0;    // the time it was given
  double start_ms = 0;  // when it started, from the start of the Solve
  double elapsed_ms = 0;
  bool found = false;
  // Every edge passed the merge's check; a path found but not certified still goes into the
  // H-Graph (the merge uses its certified parts).
  bool certified = false;
  double length = 0;      // of its path, when found
  std::string status;     // OMPL's status, or why it found no path
  std::string path_name;  // its path's name in the H-Graph ("bitstar-3"), when found
};

// The best certified path so far (SolveRequest::on_update).
struct SolveUpdate {
  double objective = 0;  // under the request's measure
  double elapsed_ms = 0;
  int inputs = 0;  // paths in the H-Graph when it was found
  std::shared_ptr<const InputPath> path;
  // "merge": the H-Graph's best path (maybe post-optimized); else the best input it took.
};

struct SolveRequest {
  Config start;
  Config goal;
  MeasureSpec measure;
  // The merge's options. optimize_ms: < 0 (automatic) spends what is left of the budget on the
  // post-optimization of the last query, 0 turns it off; a positive value is an error (the
  // budget sets it). threads: the merge's threads (0 = all cores).
  MergeOptions merge;
  // The whole call's wall time, in [kMinSolveBudgetS, kMaxSolveBudgetS]: planning, merging,
  // post-optimization. The result comes within 10% of it, as a rule.
  double budget_s = 3;
  // Empty: DefaultPortfolio(). At most kMaxSolveRuns runs in all.
  std::vector<PortfolioEntry> portfolio;
  // Share of the budget in which planners may run, in (0, 1]; < 0: kDefaultPlanFraction. The
  // rest (and whatever the planners leave) goes to merging their paths. When no query has
  // certified a path by then (none arrived, or those that did have no certified stretch from
  // start to goal), the planners go on until one is certified (at most to 0.9 of the budget).
  double plan_fraction = -1;
  // Planner runs at once, at most; 0: merge.threads (all cores if that is 0). Fewer run when
  // start_beside refuses tasks (a busy pool).
  int parallel = 0;
  // Starts `task` (planner runs, one after the other until none is left) on another thread now
  // and returns true, or returns false without running it when no thread is free for it (the
  // server's worker pool: every worker busy, or its admission queue full). Called from the
  // calling thread only. Unset: each task gets a std::thread of its own. While fewer than
  // `parallel` tasks go on and no path waits to be merged, the calling thread plans a run
  // itself: a pool of one worker plans one run at a time, between merges. Every task has
  // returned when Solve returns or throws.
  std::function<bool(std::function<void()>)> start_beside;
  uint64_t seed = 1;  // run i plans with seed PlanAttemptSeed(seed, i)
  double resolution = kDefaultResolution;
  // How the planners check their motions. kDiscrete (OMPL's own check at the resolution's
  // samples, as OMPL ships it): a planner reaches its first path several times sooner than on
  // the certificate, and the merge certifies what it takes, using a path's certified stretches
  // when an edge of it grazes an obstacle between samples (docs/performance.md, "Solve": at 1 s a
  // path on all four real-size problems instead of one). kCertified: every planned motion
  // certified as a merge certifies it.
  OmplMotionCheck plan_check = OmplMotionCheck::kDiscrete;
  // Called from the calling thread each time the best certified path improves.
  std::function<void(const SolveUpdate&)> on_update;
  // Called from the calling thread as each run ends (found or not), in the order they end.
  std::function<void(const SolveRun&)> on_run;
  // Stops every planner and the merge: Solve throws Error(kCancelled). Its deadline, if set,
  // stops the call as a cancel does.
  CancelToken cancel;
};

struct SolveResult {
  // A certified path was found: `result` holds it, `session` the H-Graph it came from.
  bool found = false;
  // Without a path: why (no run found one in time, or none of their paths had a certified
  // stretch from start to goal).
  std::string message;
  // Every path the planners found, in the order they went into the H-Graph. Null when none.
  std::unique_ptr<HybridizationSession> session;
  // The best result under the measure: the last query's, or an earlier one's if that was
  // better (the post-optimization is random), whose `inputs` are then the paths merged so far.
  MergeResult result;
  std::vector<InputPath> inputs;  // in the H-Graph's order
  std::vector<SolveRun> runs;     // in the order they started
  double plan_ms = 0;             // when the last planner stopped
  double elapsed_ms = 0;
  int updates = 0;  // on_update calls
  // The most planner runs that went on at once (at most `parallel`), and how many of the runs
  // the calling thread ran itself (start_beside refused them).
  int most_runs_at_once = 0;
  int runs_on_caller = 0;
};

// Resolves the request's defaults (portfolio, plan fraction, parallel runs) and validates it:
// InputError naming "budget_s", "portfolio[i].runs", "portfolio", "plan_fraction", "parallel",
// "merge.optimize_ms", "start" or "goal" (wrong dimension, out of bounds, in collision).
SolveRequest ResolveSolveRequest(const MotionChecker& checker, const SolveRequest& request);

// Runs the portfolio and merges its paths within request.budget_s. Throws InputError as
// ResolveSolveRequest and Error(kCancelled / kDeadlineExceeded) when request.cancel stops it.
// A budget in which no planner finds a path is not an error: found is false, with a message.
SolveResult Solve(const ClearanceChecker& checker, const SolveRequest& request);

}  // namespace hgraph
