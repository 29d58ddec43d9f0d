// Checking paths on their own, the way a merge checks its inputs. `hgraph check` and the
// CheckPaths RPC run CheckPaths, and the merge builds its input reports with ReportInputPath, so
// "valid" and every reported quality mean the same thing in all three: a path that passes
// `hgraph check` is one a merge accepts as an input.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/progress.h"
#include "core/measure/measure.h"
#include "core/motion/motion_checker.h"
#include "core/path/path.h"

namespace hgraph {

// Why a path is invalid (hgraph.v1.InputReport.Cause).
enum class InvalidCause { kNone, kCollision, kOutOfBounds };

// What the check of one path found (ReportInputPath below builds it, for a merge's inputs and
// for CheckPaths alike).
struct InputReport {
  std::string name;
  bool valid = false;
  int invalid_edge = -1;  // first invalid edge (waypoint i to i+1), or -1
  std::string invalid_reason;
  PathQuality quality;
  int waypoints = 0;
  double invalid_at = -1;  // the motion's parameter where the check failed on invalid_edge
  InvalidCause invalid_cause = InvalidCause::kNone;
  // Every stretch between clearance samples of every edge proven free (EdgeReport::certified).
  bool certified = false;
  // Every edge of the path was checked, so `valid` and the qualities are established. False
  // when lazy evaluation without report_inputs left some edges unchecked: the length is exact,
  // the path is invalid if a checked edge is (invalid_edge names it), and no clearance is
  // reported.
  bool checked = true;
};

enum class CheckMode {
  // Every edge with its clearance profile and the clearance certificate of
  // core/motion/local_planner.h, exactly as a merge checks its input edges: a stretch between two
  // samples is proven free or halved until it is, so an obstacle thinner than the resolution is
  // found. Reports every measure.
  kCertified,
  // Every edge with the collision test at the resolution's samples only (OMPL's discrete motion
  // validator; no distance queries): cheaper, but it accepts an edge that grazes an obstacle
  // between two samples. Reports the length only.
  kSampled,
};

// "certified" or "sampled".
const char* CheckModeName(CheckMode mode);
// Parses the names above; throws InputError naming `field` otherwise.
CheckMode ParseCheckMode(const std::string& name, const std::string& field);
// "collision", "out of bounds" or "none".
const char* InvalidCauseName(InvalidCause cause);

struct PathCheckRequest {
  std::vector<InputPath> paths;
  CheckMode mode = CheckMode::kCertified;
  double k = kDefaultInverseClearanceK;  // exponent of the reported inverse clearance, >= 0
  int threads = 0;                       // worker threads; 0 = all cores
  // Names the paths in errors: "<field>[i].waypoints[j]" (the service passes "paths.paths").
  std::string field = "paths";
  ProgressCallback progress;  // phase "check", one unit per edge; may be empty
  CancelToken cancel;
};

struct PathCheckResult {
  std::vector<InputReport> paths;  // in request order
  int64_t edges_checked = 0;
  int64_t collision_checks = 0;
  int64_t distance_queries = 0;
  double elapsed_ms = 0;
};

// Validates the request (InputError naming "<field>" when there are no paths,
// "<field>[i].waypoints" for a path without waypoints, "<field>[i].waypoints[j]..." for a
// waypoint that does not fit the space, "k" and "threads"), normalises the waypoints as a merge
// does, then checks every edge of every path in parallel (all of them: the counts do not depend
// on the order the threads run in). A path of one waypoint is checked as the motion that stays
// there. Unnamed paths are called "path<i>". Throws Error(kCancelled / kDeadlineExceeded) when
// stopped. Thread safe if the checker is.
PathCheckResult CheckPaths(const MotionChecker& checker, const PathCheckRequest& request);

// The report on one path from the reports of its edges: edges[j] is the motion from waypoint j
// to j + 1 (for a path of one waypoint, edges[0] is the motion that stays there), or nullptr
// where the path does not move in the H-Graph (a repeated shared start or goal). A valid path
// gets every measure with exponent k if every edge has a clearance profile, else its length
// only; an invalid one gets its length, zero clearances, its first invalid edge, where on it
// (invalid_at) and why (leaving the space's bounds or a collision, told apart by where the
// robot is at that point).
InputReport ReportInputPath(const Space& space, const InputPath& path,
                            const std::vector<const EdgeReport*>& edges, double k);

}  // namespace hgraph
