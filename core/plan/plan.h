// Input paths from OMPL's sampling-based planners, checked by our own MotionChecker
// (docs/design.md, "Layout"). OMPL is a private dependency: nothing here includes its headers.
//
// Planners (OMPL 1.5.2, the Debian package):
//   prm         PRM without cycles, as in the paper: OMPL's PRM with a connection filter that
//               only joins a new milestone to milestones of *other* components, so the roadmap is
//               a forest (OMPL's expansion step may still close the rare cycle through a random
//               bounce motion). Returns its first solution: in a forest the path between start
//               and goal never changes once they are connected, so more time would not help.
//   prm-cycles  OMPL's PRM as shipped: it tries its 10 nearest neighbours whatever their
//               component, so the roadmap has cycles. Given a path-length objective that can
//               never be met, it spends its whole time budget improving the roadmap and returns
//               the shortest roadmap path (the paper's "PRM with cycles").
//   prmstar     OMPL's PRM* (k-nearest with k growing as log n); uses the whole budget.
//   rrt, rrtconnect, lazyprm
//               OMPL's RRT, RRT-Connect and LazyPRM; each returns its first solution.
//   rrtstar, informed-rrtstar, bitstar, aitstar
//               OMPL's asymptotically optimal RRT*, Informed RRT*, BIT* and AIT* (as prmstar):
//               given a path-length objective that is never met, each uses its whole time budget
//               and returns the shortest path it found (IsOptimizingPlanner).
//
// Determinism: every path is planned after ompl::RNG::setSeed(f(seed, index)), under a process-
// wide lock, so OMPL's objects draw the same seeds in the same order. A run is reproducible when
// the planner's result does not depend on wall-clock time: single-threaded planners that stop at
// their first solution (rrt, rrtconnect, lazyprm) reproduce exactly. OMPL's PRM builds its
// roadmap in timed phases (0.4 s of sampling, then 0.2 s of random-bounce expansion, ...) and
// checks for a solution from a second thread every millisecond, so prm reproduces when it finds
// its path within the first sampling phase, and prm-cycles / prmstar, which stop on the clock,
// do not reproduce at all. A different OMPL version or a different machine's FP may also differ.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/common/progress.h"
#include "core/motion/motion_checker.h"
#include "core/path/path.h"
#include "core/plan/baselines.h"

namespace hgraph {

enum class PlannerType {
  kPRM,
  kPRMCycles,
  kPRMStar,
  kRRT,
  kRRTConnect,
  kLazyPRM,
  kRRTStar,
  kInformedRRTStar,
  kBITStar,
  kAITStar,
};

// Every planner, in the order above.
const std::vector<PlannerType>& AllPlannerTypes();
// "prm", "prm-cycles", "prmstar", "rrt", "rrtconnect", "lazyprm", "rrtstar", "informed-rrtstar",
// "bitstar", "aitstar".
const char* PlannerTypeName(PlannerType type);
// Parses the names above (and "rrt-connect", "prm-star", "lazy-prm", "rrt-star",
// "informed-rrt-star", "bit-star", "ait-star"); throws InputError naming `field` and listing the
// known names otherwise.
PlannerType ParsePlannerType(const std::string& name, const std::string& field);
// Whether the planner spends its whole time budget improving its path (prm-cycles, prmstar and
// the four asymptotically optimal ones) rather than stopping at its first solution.
bool IsOptimizingPlanner(PlannerType type);

struct PlanAttempt;
// Called once per path found, from the calling thread, before the next path is planned;
// `attempt` says which one it is, its time, and whether it passed our check (certified).
using PathCallback = std::function<void(const PlanAttempt& attempt, const InputPath& path)>;

// Why an attempt returned no path.
enum class PlanFailure {
  kNone,            // it found one
  kNoSolution,      // OMPL found no exact solution within the time budget (PlanAttempt.status)
  kOtherEndpoints,  // OMPL's path did not start at the start or end at the goal
  kInvalidEdge,     // an edge of OMPL's path fails our checker (PlanAttempt.invalid_edge)
};

// Called once per attempt that found no path, from the calling thread, before the next one.
using FailureCallback = std::function<void(const PlanAttempt& attempt)>;

struct PlanRequest {
  PlannerType planner = PlannerType::kPRM;
  Config start;
  Config goal;
  int count = 1;        // paths to plan, one planner run each
  double time_s = 1.0;  // budget per path (wall time)
  uint64_t seed = 1;    // path i is planned with a seed derived from (seed, i)
  // Shortcut each path with OMPL's PathSimplifier (see ShortcutPath) before returning it.
  bool simplify = false;
  // Longest motion OMPL checks in one step, as a fraction of the space's extent: pass the local
  // planner's resolution, so that OMPL's own discretisation matches ours.
  double resolution = kDefaultResolution;
  // How OMPL checks the motions it plans with (baselines.h): kCertified, the check a merge makes
  // (the paths come out certified, as a rule); kDiscrete, OMPL's own check at the resolution's
  // samples, as OMPL users run it: faster, but a path may graze an obstacle between samples.
  OmplMotionCheck motion_check = OmplMotionCheck::kCertified;
  // Return a path even when an edge of it fails our certified check (PlanAttempt::certified
  // false, invalid_edge set): a merge still uses its certified parts. Off: such a path is a
  // failed attempt (PlanFailure::kInvalidEdge).
  bool keep_uncertified = false;
  PathCallback on_path;        // may be empty
  FailureCallback on_failure;  // may be empty
  CancelToken cancel;  // stops the current run and throws Error(kCancelled/kDeadlineExceeded)
  // Ends the current run as its time would (its best path so far is returned, not an error), and
  // every later attempt at once: a caller that has what it needs stops an optimizing planner.
  CancelToken finish;
};

// What happened to one requested path.
struct PlanAttempt {
  int index = 0;
  // The seed OMPL's generator got for this attempt: PlanAttemptSeed(request.seed, index).
  uint64_t seed = 0;
  bool found = false;
  double elapsed_ms = 0;
  // OMPL's planner status ("Exact solution", "Timeout", ...) or why the path was rejected.
  std::string status;
  int waypoints = 0;
  double length = 0;
  PlanFailure failure = PlanFailure::kNone;
  // With kInvalidEdge, or a path kept uncertified: the first edge our checker rejects.
  int invalid_edge = -1;
  // Found, and every edge passed our check (a merge's check of its inputs). A path kept with
  // keep_uncertified has found true and certified false.
  bool certified = false;
};

struct PlanResult {
  // The paths found, in index order; each one starts at `start`, ends at `goal` and passed
  // MotionChecker::CheckEdge on every edge, unless keep_uncertified kept it with the attempt's
  // certified false. Named "<planner>-<index>".
  std::vector<InputPath> paths;
  std::vector<PlanAttempt> attempts;  // one per requested path
};

// The seed of attempt `index` of a request with `seed` (each attempt draws its own).
uint64_t PlanAttemptSeed(uint64_t seed, int index);

// Plans request.count paths. A run that finds nothing in time is reported in `attempts` and to
// request.on_failure (it is not an error). Throws InputError for a bad request (count < 1, time_s
// <= 0, start or goal of the wrong dimension, out of bounds or in collision) and
// Error(kCancelled/kDeadlineExceeded) when request.cancel stops it. Thread safe, but runs one OMPL
// planner at a time per process (see "Determinism").
PlanResult PlanPaths(const MotionChecker& checker, const PlanRequest& request);

}  // namespace hgraph
