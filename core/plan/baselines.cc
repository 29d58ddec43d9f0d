#include "core/plan/baselines.h"

#include <ompl/geometric/PathHybridization.h>
#include <ompl/geometric/PathSimplifier.h>

#include <cstdint>
#include <mutex>
#include <string>

#include "core/common/error.h"
#include "core/plan/ompl_bridge.h"

namespace hgraph {
namespace ob = ompl::base;
namespace og = ompl::geometric;
using namespace plan_internal;

namespace {

// One path through OMPL's PathSimplifier: the path validated (two waypoints at least), OMPL seeded
// under its lock, the simplifier made on `checker`; `simplify(simplifier, path, lock)` runs on
// OMPL's copy of the path and releases the lock if what it runs draws no seed. Keeps start and
// goal bit for bit.
template <typename Simplify>
InputPath SimplifyWithOmpl(const MotionChecker& checker, const InputPath& path, uint64_t seed,
                           double resolution, OmplMotionCheck motion_check,
                           const Simplify& simplify) {
  const Space& space = checker.space();
  ValidatePath(space, path, "path", 2);
  QuietOmplLogging();
  auto lock = LockOmplRandomness();
  SeedOmpl(seed);
  const ob::SpaceInformationPtr si = MakeSpaceInformation(checker, resolution, motion_check);
  og::PathGeometric omplPath = ToOmplPath(si, space, path);
  og::PathSimplifier simplifier(si);
  simplify(simplifier, omplPath, lock);
  InputPath out = FromOmplPath(space, omplPath, path.name);
  // OMPL keeps the end states, but through a copy; restore them bit for bit.
  out.waypoints.front() = path.waypoints.front();
  out.waypoints.back() = path.waypoints.back();
  return out;
}

}  // namespace

InputPath ShortcutPath(const MotionChecker& checker, const InputPath& path,
                       const ShortcutOptions& options) {
  return SimplifyWithOmpl(checker, path, options.seed, options.resolution,
                          OmplMotionCheck::kCertified,
                          [&](og::PathSimplifier& simplifier, og::PathGeometric& omplPath,
                              std::unique_lock<std::mutex>& lock) {
                            // The simplifier's own generator is drawn; reduceVertices and
                            // shortcutPath use only it.
                            lock.unlock();
                            for (int round = 0; round < options.max_rounds; ++round) {
                              // Non-short-circuit: both heuristics run every round.
                              const bool reduced = simplifier.reduceVertices(omplPath);
                              const bool shortened = simplifier.shortcutPath(omplPath);
                              if (!reduced && !shortened) break;
                            }
                          });
}

InputPath SimplifyMaxPath(const MotionChecker& checker, const InputPath& path,
                          const SimplifyMaxOptions& options) {
  return SimplifyWithOmpl(checker, path, options.seed, options.resolution, options.motion_check,
                          [](og::PathSimplifier& simplifier, og::PathGeometric& omplPath,
                             std::unique_lock<std::mutex>&) { simplifier.simplifyMax(omplPath); });
}

InputPath OmplHybridize(const MotionChecker& checker, const std::vector<InputPath>& paths,
                        const OmplHybridizationOptions& options) {
  const Space& space = checker.space();
  if (paths.empty()) throw InputError("paths", "needs at least one path");
  for (size_t i = 0; i < paths.size(); ++i) {
    ValidatePath(space, paths[i], "paths[" + std::to_string(i) + "]", 2);
  }
  QuietOmplLogging();
  const ob::SpaceInformationPtr si =
      MakeSpaceInformation(checker, options.resolution, options.motion_check);
  og::PathHybridization hybridization(si);
  // The hybridizer keeps pointers to the recorded paths; they live until it is done.
  std::vector<og::PathGeometricPtr> recorded;
  for (const InputPath& p : paths) {
    recorded.push_back(std::make_shared<og::PathGeometric>(ToOmplPath(si, space, p)));
    hybridization.recordPath(recorded.back(), options.match_across_gaps);
  }
  hybridization.computeHybridPath();
  const og::PathGeometricPtr& hybrid = hybridization.getHybridPath();
  if (hybrid == nullptr || hybrid->getStateCount() < 2) {
    throw Error(ErrorCode::kFailedPrecondition, "paths",
                "OMPL's PathHybridization found no hybrid path");
  }
  return FromOmplPath(space, *hybrid, "ompl-hybridization");
}

}  // namespace hgraph
