#include "core/plan/plan.h"

#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/samplers/informed/RejectionInfSampler.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/planners/informedtrees/AITstar.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/prm/LazyPRM.h>
#include <ompl/geometric/planners/prm/PRM.h>
#include <ompl/geometric/planners/prm/PRMstar.h>
#include <ompl/geometric/planners/rrt/InformedRRTstar.h>
#include <ompl/geometric/planners/rrt/RRT.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "core/common/client_text.h"
#include "core/common/error.h"
#include "core/plan/baselines.h"
#include "core/plan/ompl_bridge.h"

namespace hgraph {
namespace ob = ompl::base;
namespace og = ompl::geometric;
using namespace plan_internal;

namespace {

// The paper's PRM: a new milestone is only connected to milestones of other components, so
// the roadmap stays a forest (Nieuwenhuisen and Overmars: cycles cost a quadratic number of
// edges; the paper's H-Graph adds the cycles afterwards, between paths).
class ForestPRM final : public og::PRM {
 public:
  explicit ForestPRM(const ob::SpaceInformationPtr& si) : og::PRM(si) {
    setName("PRM-forest");
    setConnectionFilter([this](const Vertex& m, const Vertex& n) { return !sameComponent(m, n); });
  }
};

// Path length whose informed sampler (BIT*, AIT*, Informed RRT* sample within the ellipse of
// paths that could improve on the best) rejects uniform samples by the cost heuristic: OMPL's
// direct sampler takes only a bare RealVector, SE2 or SE3 space, and ours is a compound of
// components (ompl_bridge.h). The heuristic is our weighted distance, so the rejection is exact.
class CompoundPathLength final : public ob::PathLengthOptimizationObjective {
 public:
  using ob::PathLengthOptimizationObjective::PathLengthOptimizationObjective;
  ob::InformedSamplerPtr allocInformedStateSampler(const ob::ProblemDefinitionPtr& pdef,
                                                   unsigned int max_calls) const override {
    return std::make_shared<ob::RejectionInfSampler>(pdef, max_calls);
  }
};

ob::PlannerPtr MakePlanner(PlannerType type, const ob::SpaceInformationPtr& si) {
  switch (type) {
    case PlannerType::kPRM: return std::make_shared<ForestPRM>(si);
    case PlannerType::kPRMCycles: return std::make_shared<og::PRM>(si);
    case PlannerType::kPRMStar: return std::make_shared<og::PRMstar>(si);
    case PlannerType::kRRT: return std::make_shared<og::RRT>(si);
    case PlannerType::kRRTConnect: return std::make_shared<og::RRTConnect>(si);
    case PlannerType::kLazyPRM: return std::make_shared<og::LazyPRM>(si);
    case PlannerType::kRRTStar: return std::make_shared<og::RRTstar>(si);
    case PlannerType::kInformedRRTStar: return std::make_shared<og::InformedRRTstar>(si);
    case PlannerType::kBITStar: return std::make_shared<og::BITstar>(si, "kBITstar");
    case PlannerType::kAITStar: return std::make_shared<og::AITstar>(si);
  }
  HGRAPH_CHECK(false);
  return nullptr;
}

void ValidateEndpoint(const MotionChecker& checker, const Config& q, const std::string& field) {
  const Space& space = checker.space();
  space.Validate(q, field);
  if (!space.InBounds(q)) throw InputError(field, "is outside the space's bounds");
  if (!checker.IsValid(space.Normalize(q))) throw InputError(field, "is in collision");
}

// The index of the first edge the checker does not certify, or -1: the stretches between its
// samples proven free (touching contact rejected), as a merge requires of the input edges it
// takes, so that a path that passes here is one a merge can use whole. `cancel` stops it
// (Error(kCancelled/kDeadlineExceeded)): certifying a long path on a large mesh takes hundreds of
// milliseconds, which a Solve that stops its planners at its budget cannot wait for.
int FirstInvalidEdge(const MotionChecker& checker, const InputPath& path,
                     const CancelToken& cancel) {
  for (size_t k = 0; k + 1 < path.waypoints.size(); ++k) {
    cancel.ThrowIfStopped();
    // Valid and certified, as a merge takes its inputs' edges (a profile may find a motion free
    // at every sample and still certify no cover of it).
    const EdgeReport report = checker.CheckEdge({.from = &path.waypoints[k],
                                                 .to = &path.waypoints[k + 1],
                                                 .proof = EdgeProof::kCertificate,
                                                 .cancel = &cancel});
    if (report.state != EdgeState::kValid || !report.certified) return static_cast<int>(k);
  }
  return -1;
}

std::string FormatSeconds(double s) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g s", s);
  return text;
}

}  // namespace

const char* PlannerTypeName(PlannerType type) {
  switch (type) {
    case PlannerType::kPRM: return "prm";
    case PlannerType::kPRMCycles: return "prm-cycles";
    case PlannerType::kPRMStar: return "prmstar";
    case PlannerType::kRRT: return "rrt";
    case PlannerType::kRRTConnect: return "rrtconnect";
    case PlannerType::kLazyPRM: return "lazyprm";
    case PlannerType::kRRTStar: return "rrtstar";
    case PlannerType::kInformedRRTStar: return "informed-rrtstar";
    case PlannerType::kBITStar: return "bitstar";
    case PlannerType::kAITStar: return "aitstar";
  }
  return "?";
}

const std::vector<PlannerType>& AllPlannerTypes() {
  static const std::vector<PlannerType> all = {
      PlannerType::kPRM,     PlannerType::kPRMCycles,       PlannerType::kPRMStar,
      PlannerType::kRRT,     PlannerType::kRRTConnect,      PlannerType::kLazyPRM,
      PlannerType::kRRTStar, PlannerType::kInformedRRTStar, PlannerType::kBITStar,
      PlannerType::kAITStar};
  return all;
}

PlannerType ParsePlannerType(const std::string& name, const std::string& field) {
  std::string known;
  for (PlannerType type : AllPlannerTypes()) {
    if (name == PlannerTypeName(type)) return type;
    known += (known.empty() ? "" : ", ") + std::string(PlannerTypeName(type));
  }
  if (name == "rrt-connect") return PlannerType::kRRTConnect;
  if (name == "prm-star") return PlannerType::kPRMStar;
  if (name == "lazy-prm") return PlannerType::kLazyPRM;
  if (name == "rrt-star") return PlannerType::kRRTStar;
  if (name == "informed-rrt-star") return PlannerType::kInformedRRTStar;
  if (name == "bit-star") return PlannerType::kBITStar;
  if (name == "ait-star") return PlannerType::kAITStar;
  throw InputError(field, "unknown planner '" + ClientText(name) + "' (known: " + known + ")");
}

bool IsOptimizingPlanner(PlannerType type) {
  switch (type) {
    case PlannerType::kPRMCycles:
    case PlannerType::kPRMStar:
    case PlannerType::kRRTStar:
    case PlannerType::kInformedRRTStar:
    case PlannerType::kBITStar:
    case PlannerType::kAITStar: return true;
    default: return false;
  }
}

namespace {

// One attempt's OMPL objects. Everything in it that draws a seed from OMPL's generator is made
// under the lock (LockOmplRandomness); the search runs without it.
struct AttemptProblem {
  ob::ProblemDefinitionPtr pdef;
  ob::PlannerPtr planner;
  // When the run's time is up (steady clock ticks; set as it starts): from then on the motion
  // validator refuses every motion unchecked, as it does once the request's tokens stop it.
  std::shared_ptr<std::atomic<std::chrono::steady_clock::rep>> stop_at =
      std::make_shared<std::atomic<std::chrono::steady_clock::rep>>(
          std::chrono::steady_clock::time_point::max().time_since_epoch().count());
};

AttemptProblem MakeAttemptProblem(const MotionChecker& checker, const PlanRequest& request,
                                  const Config& start, const Config& goal, uint64_t seed) {
  const Space& space = checker.space();
  auto lock = LockOmplRandomness();
  SeedOmpl(seed);
  AttemptProblem problem;
  const ob::SpaceInformationPtr si = MakeSpaceInformation(
      checker, request.resolution, request.motion_check,
      [stop_at = problem.stop_at, cancel = request.cancel, finish = request.finish] {
        return cancel.stopped() || finish.stopped() ||
               std::chrono::steady_clock::now().time_since_epoch().count() >= stop_at->load();
      });
  // PRM asks for two samplers (a valid-state sampler over a plain one, and a plain one), the
  // others for one.
  PrepareSamplers(si, 2);
  problem.pdef = std::make_shared<ob::ProblemDefinition>(si);
  ob::ScopedState<> s(si), g(si);
  ToOmpl(space, start, s.get());
  ToOmpl(space, goal, g.get());
  // A tolerance of 0 would make RRT's goal test depend on rounding; the path's last state is
  // replaced by the exact goal afterwards.
  problem.pdef->setStartAndGoalStates(s, g, 1e-9);
  if (IsOptimizingPlanner(request.planner)) {
    // An objective whose threshold (0) is never met: the planner keeps improving until the time
    // is up instead of returning its first solution (PRM with cycles would stop at its first).
    problem.pdef->setOptimizationObjective(std::make_shared<CompoundPathLength>(si));
  }
  problem.planner = MakePlanner(request.planner, si);
  problem.planner->setProblemDefinition(problem.pdef);
  problem.planner->setup();
  return problem;
}

// Runs the planner until it stops (a solution, the time budget, or the request's cancel) and
// records its time and OMPL's status in `attempt`.
void Solve(const AttemptProblem& problem, const PlanRequest& request, PlanAttempt* attempt) {
  const CancelToken cancel = request.cancel;
  const CancelToken finish = request.finish;
  const ob::PlannerTerminationCondition ptc =
      ob::plannerOrTerminationCondition(ob::timedPlannerTerminationCondition(request.time_s),
                                        ob::PlannerTerminationCondition([cancel, finish] {
                                          return cancel.stopped() || finish.stopped();
                                        }));
  const auto t0 = std::chrono::steady_clock::now();
  problem.stop_at->store((t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                   std::chrono::duration<double>(request.time_s)))
                             .time_since_epoch()
                             .count());
  const ob::PlannerStatus status = problem.planner->solve(ptc);
  attempt->elapsed_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  attempt->status = status.asString();
}

// Marks `attempt` failed for `failure`, with `status` as the text that says why.
InputPath Fail(PlanAttempt* attempt, PlanFailure failure, std::string status) {
  attempt->failure = failure;
  attempt->status = std::move(status);
  return {};
}

// The attempt's solution as an input path named `name` with the request's exact endpoints,
// shortcut if asked, every edge passing our checker; or an empty path with the attempt's
// failure set.
InputPath AcceptSolution(const MotionChecker& checker, const PlanRequest& request,
                         const Config& start, const Config& goal, const ob::ProblemDefinition& pdef,
                         const std::string& name, PlanAttempt* attempt) {
  const Space& space = checker.space();
  if (!pdef.hasExactSolution()) {
    return Fail(attempt, PlanFailure::kNoSolution,
                "no path in " + FormatSeconds(request.time_s) + " (OMPL: " + attempt->status + ")");
  }
  InputPath path = FromOmplPath(space, *pdef.getSolutionPath()->as<og::PathGeometric>(), name);
  if (request.simplify) {
    // Takes the lock itself, for as long as it draws seeds.
    path = ShortcutPath(checker, path,
                        {.seed = request.seed + static_cast<uint64_t>(attempt->index),
                         .resolution = request.resolution});
  }
  if (path.waypoints.empty()) {
    return Fail(attempt, PlanFailure::kNoSolution, "the planner returned an empty path");
  }
  // Exact endpoints: every input of a merge must share them bit for bit.
  if (space.Distance(path.waypoints.front(), start) > kEndpointTolerance ||
      space.Distance(path.waypoints.back(), goal) > kEndpointTolerance) {
    return Fail(attempt, PlanFailure::kOtherEndpoints,
                "planner returned a path with other endpoints");
  }
  path.waypoints.front() = start;
  path.waypoints.back() = goal;
  if (path.waypoints.size() == 1) path.waypoints.push_back(goal);
  const int bad = FirstInvalidEdge(checker, path, request.cancel);
  attempt->certified = bad < 0;
  if (bad >= 0) {
    attempt->invalid_edge = bad;
    if (request.keep_uncertified) {
      attempt->status = "kept uncertified: edge " + std::to_string(bad) +
                        " is not certified by our checker (a merge uses the certified parts)";
      return path;
    }
    return Fail(attempt, PlanFailure::kInvalidEdge,
                "rejected: edge " + std::to_string(bad) + " is not certified by our checker");
  }
  return path;
}

}  // namespace

uint64_t PlanAttemptSeed(uint64_t seed, int index) {
  return seed * 0x100000001b3ULL + static_cast<uint64_t>(index);
}

PlanResult PlanPaths(const MotionChecker& checker, const PlanRequest& request) {
  const Space& space = checker.space();
  if (request.count < 1) {
    throw InputError("count", "must be at least 1, got " + std::to_string(request.count));
  }
  if (!(request.time_s > 0) || !std::isfinite(request.time_s)) {
    throw InputError("time_s",
                     "must be positive and finite, got " + std::to_string(request.time_s));
  }
  ValidateEndpoint(checker, request.start, "start");
  ValidateEndpoint(checker, request.goal, "goal");
  const Config start = space.Normalize(request.start);
  const Config goal = space.Normalize(request.goal);
  QuietOmplLogging();

  PlanResult result;
  for (int index = 0; index < request.count; ++index) {
    request.cancel.ThrowIfStopped();
    PlanAttempt attempt{.index = index, .seed = PlanAttemptSeed(request.seed, index)};
    const AttemptProblem problem = MakeAttemptProblem(checker, request, start, goal, attempt.seed);
    Solve(problem, request, &attempt);
    request.cancel.ThrowIfStopped();
    const std::string name =
        std::string(PlannerTypeName(request.planner)) + "-" + std::to_string(index);
    InputPath path = AcceptSolution(checker, request, start, goal, *problem.pdef, name, &attempt);
    if (path.waypoints.empty()) {
      if (request.on_failure) request.on_failure(attempt);
    } else {
      attempt.found = true;
      attempt.waypoints = static_cast<int>(path.waypoints.size());
      attempt.length = PathLength(space, path);
      if (request.on_path) request.on_path(attempt, path);
      result.paths.push_back(std::move(path));
    }
    result.attempts.push_back(attempt);
  }
  return result;
}

}  // namespace hgraph
