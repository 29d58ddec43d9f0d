#include "core/solve/solve.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#include "core/common/error.h"

namespace hgraph {
namespace {

using Clock = std::chrono::steady_clock;

// A run shorter than this is not started: OMPL's setup alone takes about as long.
constexpr double kMinRunS = 0.005;
// The merge's hard stop, past the budget: a query that would run longer is abandoned and the
// best result found before it stands (the deadline is honoured within 10%).
constexpr double kHardStopShare = 0.05;
// The last post-optimization ends this share of the budget (at least kMinMarginS) before the
// budget's end, for the query's own finish (the final search, the report).
constexpr double kMarginShare = 0.03;
constexpr double kMinMarginS = 0.005;
// The latest a planner may plan while no path is certified (RunBoard), as a share of the budget.
constexpr double kLastPlanShare = 0.9;
// While planners run, each query's post-optimization gets at most this share of the budget, so
// that the paths that arrive meanwhile wait little.
constexpr double kInterimOptimizeShare = 0.05;

std::string Seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g s", s);
  return text;
}

double MsBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// The runs of a portfolio in the order they start, kinds interleaved so that each wave mixes
// them. As a rule the planners that stop at their first solution first (their paths arrive early,
// and then leave the optimizing ones the rest of the time), then the optimizing ones. But when
// the optimizing runs are fewer than the runs at once (`parallel`), they start first: each keeps
// a slot for the whole planning time, and the others run one after another in the slots left
// (in a short budget, an optimizing run started after them would get little or no time).
std::vector<PlannerType> RunOrder(const std::vector<PortfolioEntry>& portfolio, int parallel) {
  int optimizing_runs = 0;
  for (const PortfolioEntry& e : portfolio) {
    optimizing_runs += IsOptimizingPlanner(e.planner) ? e.runs : 0;
  }
  const bool optimizing_first = optimizing_runs > 0 && optimizing_runs < parallel;
  std::vector<PlannerType> order;
  for (bool optimizing : {optimizing_first, !optimizing_first}) {
    std::vector<PortfolioEntry> left;
    for (const PortfolioEntry& e : portfolio) {
      if (IsOptimizingPlanner(e.planner) == optimizing) left.push_back(e);
    }
    bool any = true;
    while (any) {
      any = false;
      for (PortfolioEntry& e : left) {
        if (e.runs > 0) {
          order.push_back(e.planner);
          --e.runs;
          any = true;
        }
      }
    }
  }
  return order;
}

// The planner runs, shared by the planner tasks and the merging thread. Thread safe.
class RunBoard {
 public:
  // Runs end by plan_end once a query has certified a path (Certified), and by `last` (the
  // budget's end, less the merge's margin) while none has: a path that fails the certified check
  // and has no certified stretch from start to goal is no reason to stop planning.
  RunBoard(std::vector<PlannerType> order, int parallel, Clock::time_point started,
           Clock::time_point plan_end, Clock::time_point last)
      : order_(std::move(order)),
        parallel_(parallel),
        started_(started),
        plan_end_(plan_end),
        last_(last) {
    for (PlannerType type : order_) optimizing_left_ += IsOptimizingPlanner(type) ? 1 : 0;
  }

  // The next run to start and its time, or false when there is none (or no time left for one).
  // `on_caller`: the merging thread plans the run itself (no worker took it) and merges nothing
  // meanwhile, so it takes a run that stops at its first path before an optimizing one, which
  // would hold it for the whole planning time.
  bool Next(bool on_caller, int* index, PlannerType* planner, double* time_s, double* start_ms) {
    std::lock_guard lock(mutex_);
    const Clock::time_point now = Clock::now();
    if (ExhaustedLocked(now)) return false;
    const double left_s = std::chrono::duration<double>((found_ ? plan_end_ : last_) - now).count();
    if (on_caller && IsOptimizingPlanner(order_[next_])) {
      const auto first_solution =
          std::find_if(order_.begin() + next_, order_.end(),
                       [](PlannerType type) { return !IsOptimizingPlanner(type); });
      if (first_solution != order_.end()) std::iter_swap(order_.begin() + next_, first_solution);
    }
    *index = next_++;
    *planner = order_[*index];
    *start_ms = MsBetween(started_, now);
    if (IsOptimizingPlanner(*planner)) {
      // The optimizing runs not started yet share what is left, `parallel_` at a time.
      const int waves = (optimizing_left_ + parallel_ - 1) / parallel_;
      --optimizing_left_;
      *time_s = left_s / std::max(1, waves);
    } else {
      *time_s = left_s;  // it stops at its first path
    }
    ++running_;
    most_running_ = std::max(most_running_, running_);
    return true;
  }

  // A run has ended (with its path, when found).
  void Finish(SolveRun run, InputPath path) {
    {
      std::lock_guard lock(mutex_);
      --running_;
      ended_.push_back({std::move(run), std::move(path)});
    }
    changed_.notify_all();
  }
  // A task started by start_beside has returned (whether or not it found a run to start). It
  // notifies under the lock: once the caller sees every task done it may destroy the board, and
  // a pool task (unlike a thread) is not joined.
  void TaskDone() {
    std::lock_guard lock(mutex_);
    ++tasks_done_;
    changed_.notify_all();
  }
  // No further run starts (the ones running go on until their planner stops).
  void Stop() {
    std::lock_guard lock(mutex_);
    stopped_ = true;
  }

  // A query has found a certified path from start to goal.
  void Certified() {
    std::lock_guard lock(mutex_);
    found_ = true;
  }
  bool found() const {
    std::lock_guard lock(mutex_);
    return found_;
  }
  // No run is left to start: stopped, all started, or no time left for one.
  bool Exhausted() const {
    std::lock_guard lock(mutex_);
    return ExhaustedLocked(Clock::now());
  }
  int running() const {
    std::lock_guard lock(mutex_);
    return running_;
  }
  int most_running() const {
    std::lock_guard lock(mutex_);
    return most_running_;
  }
  int tasks_done() const {
    std::lock_guard lock(mutex_);
    return tasks_done_;
  }

  // Waits until a run ends, every run is over (none left to start, none running, all `tasks`
  // returned), fewer than `parallel` tasks go on while runs are left, or `until`; takes the runs
  // that ended. Returns whether every run is over.
  bool Wait(Clock::time_point until, int tasks,
            std::vector<std::pair<SolveRun, InputPath>>* ended) {
    std::unique_lock lock(mutex_);
    const auto over = [&] {
      return running_ == 0 && tasks_done_ == tasks && ExhaustedLocked(Clock::now());
    };
    // A task's return frees a slot for the next run.
    const auto slot = [&] {
      return tasks - tasks_done_ < parallel_ && !ExhaustedLocked(Clock::now());
    };
    changed_.wait_until(lock, until, [&] { return !ended_.empty() || over() || slot(); });
    for (auto& e : ended_) ended->push_back(std::move(e));
    ended_.clear();
    return over();
  }
  // Waits until `tasks` tasks have returned.
  void WaitTasks(int tasks) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return tasks_done_ == tasks; });
  }

  // The runs that never started (no time was left for them).
  std::vector<PlannerType> NotStarted() const {
    std::lock_guard lock(mutex_);
    return {order_.begin() + next_, order_.end()};
  }

 private:
  bool ExhaustedLocked(Clock::time_point now) const {
    if (stopped_ || next_ >= static_cast<int>(order_.size())) return true;
    return std::chrono::duration<double>((found_ ? plan_end_ : last_) - now).count() < kMinRunS;
  }

  std::vector<PlannerType> order_;
  const int parallel_;
  const Clock::time_point started_;
  const Clock::time_point plan_end_;
  const Clock::time_point last_;
  mutable std::mutex mutex_;
  bool found_ = false;  // a query has certified a path
  std::condition_variable changed_;
  int next_ = 0;
  int optimizing_left_ = 0;
  int running_ = 0;
  int most_running_ = 0;
  int tasks_done_ = 0;
  bool stopped_ = false;
  std::deque<std::pair<SolveRun, InputPath>> ended_;
};

// Starts the board's next run, if any, and plans it to its end (on the merging thread itself when
// `on_caller`: RunBoard::Next). Returns whether a run started.
bool PlanOne(const MotionChecker& checker, const SolveRequest& request, RunBoard* board,
             const CancelToken& stop, const CancelToken& finish, bool on_caller) {
  int index = 0;
  PlannerType planner = PlannerType::kPRM;
  double time_s = 0;
  double start_ms = 0;
  if (stop.stopped() || finish.stopped() ||
      !board->Next(on_caller, &index, &planner, &time_s, &start_ms)) {
    return false;
  }
  SolveRun run{.planner = planner, .index = index, .time_s = time_s, .start_ms = start_ms};
  InputPath path;
  try {
    PlanResult planned =
        PlanPaths(checker, PlanRequest{.planner = planner,
                                       .start = request.start,
                                       .goal = request.goal,
                                       .count = 1,
                                       .time_s = time_s,
                                       .seed = PlanAttemptSeed(request.seed, index),
                                       .resolution = request.resolution,
                                       .motion_check = request.plan_check,
                                       .keep_uncertified = true,
                                       .cancel = stop,
                                       .finish = finish});
    const PlanAttempt& attempt = planned.attempts.at(0);
    run.seed = attempt.seed;
    run.elapsed_ms = attempt.elapsed_ms;
    run.found = attempt.found;
    run.certified = attempt.certified;
    run.length = attempt.length;
    run.status = attempt.status;
    if (!planned.paths.empty()) {
      path = std::move(planned.paths.front());
      path.name = std::string(PlannerTypeName(planner)) + "-" + std::to_string(index);
      run.path_name = path.name;
    }
  } catch (const std::exception& e) {
    // Cancelled, or a planner that failed: the run found nothing.
    run.status = e.what();
  }
  board->Finish(std::move(run), std::move(path));
  return true;
}

}  // namespace

std::vector<PortfolioEntry> DefaultPortfolio(int parallel, double budget_s) {
  if (budget_s < kLongSolveBudgetS) {
    if (parallel < 2) return {{.planner = PlannerType::kPRM, .runs = 2}};
    // One RRT* run, fewer than the slots: it starts first and keeps its slot (RunOrder).
    return {
        {.planner = PlannerType::kRRTStar, .runs = 1},
        {.planner = PlannerType::kPRM, .runs = std::clamp(2 * parallel - 1, 1, kMaxSolveRuns - 1)}};
  }
  // RunOrder starts the PRM runs first; BIT* and RRT* share the planning time they leave.
  const int prm = std::clamp(parallel, 2, kMaxSolveRuns - 2);
  const int left = kMaxSolveRuns - prm;
  return {{.planner = PlannerType::kPRM, .runs = prm},
          {.planner = PlannerType::kBITStar, .runs = std::clamp((parallel + 1) / 2, 1, left - 1)},
          {.planner = PlannerType::kRRTStar, .runs = std::clamp(parallel / 2, 1, left / 2)}};
}

SolveRequest ResolveSolveRequest(const MotionChecker& checker, const SolveRequest& request) {
  SolveRequest out = request;
  if (!std::isfinite(request.budget_s) || request.budget_s < kMinSolveBudgetS ||
      request.budget_s > kMaxSolveBudgetS) {
    throw InputError("budget_s", "must be in [" + Seconds(kMinSolveBudgetS) + ", " +
                                     Seconds(kMaxSolveBudgetS) + "], got " +
                                     std::to_string(request.budget_s));
  }
  if (out.parallel < 0 || out.parallel > kMaxSolveRuns) {
    throw InputError("parallel", "must be in [0, " + std::to_string(kMaxSolveRuns) +
                                     "] (0 = the merge's threads), got " +
                                     std::to_string(out.parallel));
  }
  if (out.parallel == 0) {
    out.parallel = out.merge.threads > 0
                       ? out.merge.threads
                       : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  }
  if (out.portfolio.empty()) out.portfolio = DefaultPortfolio(out.parallel, out.budget_s);
  int runs = 0;
  for (size_t i = 0; i < out.portfolio.size(); ++i) {
    const int n = out.portfolio[i].runs;
    if (n < 1 || n > kMaxSolveRuns) {
      throw InputError(
          "portfolio[" + std::to_string(i) + "].runs",
          "must be in [1, " + std::to_string(kMaxSolveRuns) + "], got " + std::to_string(n));
    }
    runs += n;
  }
  if (runs > kMaxSolveRuns) {
    throw InputError("portfolio", "has " + std::to_string(runs) + " runs in all; at most " +
                                      std::to_string(kMaxSolveRuns));
  }
  if (out.plan_fraction < 0) {
    out.plan_fraction = kDefaultPlanFraction;
  } else if (!(out.plan_fraction > 0 && out.plan_fraction <= 1)) {
    throw InputError("plan_fraction",
                     "must be in (0, 1], got " + std::to_string(request.plan_fraction));
  }
  out.parallel = std::min(out.parallel, runs);
  if (out.merge.optimize_ms > 0) {
    throw InputError("merge.optimize_ms",
                     "must be unset (the budget sets the post-optimization's time) or 0 (off)");
  }
  ValidateMeasure(out.measure);
  const Space& space = checker.space();
  for (const auto& [q, field] : {std::pair{&out.start, "start"}, std::pair{&out.goal, "goal"}}) {
    space.Validate(*q, field);
    if (!space.InBounds(*q)) throw InputError(field, "is outside the space's bounds");
    *q = space.Normalize(*q);
    if (!checker.IsValid(*q)) throw InputError(field, "is in collision");
  }
  return out;
}

SolveResult Solve(const ClearanceChecker& checker, const SolveRequest& raw) {
  const Clock::time_point started = Clock::now();
  const SolveRequest request = ResolveSolveRequest(checker, raw);
  const auto at = [&](double s) {
    return started + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
  };
  const double budget = request.budget_s;
  const Clock::time_point plan_end = at(budget * request.plan_fraction);
  const Clock::time_point end = at(budget);
  const Clock::time_point optimize_end = at(budget - std::max(kMinMarginS, budget * kMarginShare));
  const std::unique_ptr<const Measure> measure = Measure::Make(request.measure);

  // The planners stop on a cancel only (each run's own time ends it within the planning time);
  // the merge also at the hard stop past the budget. A watcher passes the caller's cancel on.
  const CancelToken planners;
  // The planning time ends at plan_end once a query has certified a path (the planners still
  // running return their best path then), or else when the first certified path is found: a
  // budget whose planning share finds nothing certifiable keeps planning rather than merging
  // paths that have no certified way from start to goal.
  const CancelToken finish;
  const CancelToken merging;
  merging.SetDeadline(at(budget * (1 + kHardStopShare)));
  // While no path is certified the planners may go on to kLastPlanShare of the budget: a path that
  // arrives then still has time to be merged and reported, and a planner slow to stop (OMPL
  // polls its termination condition between iterations) still ends before the budget does.
  RunBoard board(RunOrder(request.portfolio, request.parallel), request.parallel, started, plan_end,
                 std::max(plan_end, at(budget * kLastPlanShare)));
  std::atomic<bool> finished{false};
  // Passes the caller's cancel on, and ends the planning time at plan_end once a path is
  // certified (also while the calling thread plans a run itself).
  std::thread watcher([&] {
    while (!finished.load()) {
      if (request.cancel.stopped()) {
        planners.Cancel();
        merging.Cancel();
        board.Stop();
        return;
      }
      if (!finish.stopped() && Clock::now() >= plan_end && board.found()) {
        finish.Cancel();
        board.Stop();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  // The planner tasks: each plans runs one after the other (PlanOne) until none is left, so that
  // the next run starts while the calling thread merges. In process, a thread each.
  std::vector<std::thread> own_threads;
  const std::function<bool(std::function<void()>)> start_beside =
      request.start_beside ? request.start_beside : [&](std::function<void()> task) {
        own_threads.emplace_back(std::move(task));
        return true;
      };
  int tasks = 0;  // started by start_beside
  // Starts tasks while fewer than `parallel` go on and runs are left, until one is refused (a
  // worker that is busy now may be free when the caller looks again, after a run or a merge).
  const auto start_tasks = [&] {
    while (tasks - board.tasks_done() < request.parallel && !board.Exhausted()) {
      if (!start_beside([&] {
            while (PlanOne(checker, request, &board, planners, finish, false)) {
            }
            board.TaskDone();
          })) {
        return;
      }
      ++tasks;
    }
  };
  const auto join_tasks = [&] {
    board.WaitTasks(tasks);
    for (std::thread& t : own_threads) t.join();
    own_threads.clear();
  };

  SolveResult out;
  std::optional<MergeResult> best;
  std::vector<InputPath> pending;  // paths not in an H-Graph yet (none certified so far)
  bool unmerged = false;           // a path arrived since the last query
  bool all_done = false;
  bool final_query = false;  // a query ran after the last path, with the long post-optimization
  bool stopped = false;      // the hard stop (or a cancel) interrupted a query
  MergeOptions options = request.merge;
  const auto query = [&](bool last) {
    const Clock::time_point until =
        last ? optimize_end
             : std::min(plan_end, Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(
                                                         budget * kInterimOptimizeShare)));
    try {
      if (!out.session) {
        out.session =
            std::make_unique<HybridizationSession>(checker, MergeRequest{.paths = pending,
                                                                         .measure = request.measure,
                                                                         .options = options,
                                                                         .cancel = merging});
        pending.clear();
      } else if (!pending.empty()) {
        out.session->AddPaths(pending, {}, merging);
        pending.clear();
      }
      MergeResult r = out.session->Query(request.measure, {}, merging, std::nullopt, until);
      // A result as good as the best replaces it (its report covers more inputs); only a better
      // one is an update.
      const bool better = !best || measure->Better(r.quality, best->quality);
      if (better || !measure->Better(best->quality, r.quality)) best = std::move(r);
      board.Certified();
      if (better) {
        ++out.updates;
        if (request.on_update) {
          request.on_update(SolveUpdate{.objective = best->objective,
                                        .elapsed_ms = MsSince(started),
                                        .inputs = static_cast<int>(out.inputs.size()),
                                        .path = std::make_shared<InputPath>(best->path)});
        }
      }
    } catch (const Error& e) {
      if (e.code() == ErrorCode::kFailedPrecondition) return;  // no certified path yet
      if (e.code() == ErrorCode::kCancelled || e.code() == ErrorCode::kDeadlineExceeded) {
        stopped = true;
        return;
      }
      throw;
    }
  };

  try {
    while (!stopped) {
      start_tasks();
      // A run no task took: the calling thread plans it, unless a path waits to be merged.
      bool planned_here = false;
      if (!unmerged && tasks - board.tasks_done() < request.parallel && !board.Exhausted() &&
          !request.cancel.stopped()) {
        planned_here = PlanOne(checker, request, &board, planners, finish, true);
        if (planned_here) ++out.runs_on_caller;
      }
      std::vector<std::pair<SolveRun, InputPath>> ended;
      // Wakes at plan_end to finish the planners if a path is certified by then.
      const Clock::time_point wake = planned_here                                   ? Clock::now()
                                     : finish.stopped() || Clock::now() >= plan_end ? end
                                                                                    : plan_end;
      all_done = board.Wait(wake, tasks, &ended);
      for (auto& [run, path] : ended) {
        if (request.on_run) request.on_run(run);
        if (!path.waypoints.empty()) {
          out.inputs.push_back(path);
          pending.push_back(std::move(path));
          unmerged = true;
        }
        out.runs.push_back(std::move(run));
      }
      if (all_done && out.plan_ms == 0) out.plan_ms = MsSince(started);
      if (request.cancel.stopped() || Clock::now() >= end) break;
      if (unmerged) {
        query(all_done);
        unmerged = false;
        final_query = all_done;
      }
      // Past the planning share with a certified path: the planners still running return theirs.
      if (best && Clock::now() >= plan_end && !finish.stopped()) {
        finish.Cancel();
        board.Stop();
      }
      if (all_done) break;
    }
    if (!stopped && !final_query && !request.cancel.stopped() && Clock::now() < optimize_end &&
        (out.session || !pending.empty())) {
      query(true);
    }
  } catch (...) {
    finished = true;
    planners.Cancel();
    board.Stop();
    join_tasks();
    watcher.join();
    throw;
  }
  finished = true;
  planners.Cancel();
  board.Stop();
  join_tasks();
  watcher.join();
  out.most_runs_at_once = board.most_running();
  request.cancel.ThrowIfStopped();
  if (out.plan_ms == 0) out.plan_ms = MsSince(started);

  // The runs that were still going at the end, and those that never started.
  std::vector<std::pair<SolveRun, InputPath>> late;
  board.Wait(Clock::now(), tasks, &late);
  for (auto& [run, path] : late) {
    if (request.on_run) request.on_run(run);
    out.runs.push_back(std::move(run));
  }
  std::sort(out.runs.begin(), out.runs.end(),
            [](const SolveRun& a, const SolveRun& b) { return a.index < b.index; });
  int index = static_cast<int>(out.runs.size());
  for (PlannerType type : board.NotStarted()) {
    out.runs.push_back(SolveRun{
        .planner = type, .index = index++, .status = "not started: the planning time had run out"});
  }

  out.found = best.has_value();
  if (best) {
    out.result = std::move(*best);
  } else {
    int found = 0;
    for (const SolveRun& run : out.runs) found += run.found ? 1 : 0;
    out.message = found == 0
                      ? "no path found in " + Seconds(budget) + ": none of the " +
                            std::to_string(out.runs.size()) + " planner runs found one"
                      : "no path found in " + Seconds(budget) + ": the " + std::to_string(found) +
                            " paths the planners found have no certified way from start to goal" +
                            (stopped ? " that the merge could establish in time" : "");
  }
  out.elapsed_ms = MsSince(started);
  return out;
}

}  // namespace hgraph
