// Our configuration space and motion checker as OMPL sees them. Internal to core/plan: the only
// header of the project that includes OMPL, so that OMPL stays a private dependency.
#pragma once

#include <ompl/base/MotionValidator.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/StateValidityChecker.h>
#include <ompl/geometric/PathGeometric.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "core/motion/motion_checker.h"
#include "core/path/path.h"
#include "core/plan/baselines.h"
#include "core/space/space.h"

namespace hgraph::plan_internal {

// A compound OMPL space with one subspace per component of `space`, in order: RealVector, SO2,
// SO3, SE2, SE3, each with our bounds and our translation and rotation weights, so that OMPL's
// distance (and with it its nearest neighbours, path lengths and shortcut decisions) equals
// Space::Distance. `resolution` is OMPL's longest valid segment fraction, the same fraction of
// the extent as our local planner's.
ompl::base::StateSpacePtr MakeStateSpace(const Space& space, double resolution);

void ToOmpl(const Space& space, const Config& q, ompl::base::State* state);
Config FromOmpl(const Space& space, const ompl::base::State* state);

// Validity and motion checks answered by `checker` (which must outlive the returned object). With
// kCertified the motion validator runs MotionChecker::CheckEdge, so OMPL accepts exactly the
// motions that a merge accepts; with kDiscrete it is OMPL's DiscreteMotionValidator on the
// checker's state validity. Thread safe as far as the checker is (PRM checks from two threads).
// Once `stopped` (may be empty) returns true, the kCertified validator refuses every motion
// unchecked: a planner polls its stop only between steps (PRM: between milestones, each up to ten
// motions), and the motions of a step the stop came in can no longer be of use.
ompl::base::SpaceInformationPtr MakeSpaceInformation(
    const MotionChecker& checker, double resolution,
    OmplMotionCheck motion_check = OmplMotionCheck::kCertified, std::function<bool()> stopped = {});

ompl::geometric::PathGeometric ToOmplPath(const ompl::base::SpaceInformationPtr& si,
                                          const Space& space, const InputPath& path);
// Copies the states; `name` becomes the path's name.
InputPath FromOmplPath(const Space& space, const ompl::geometric::PathGeometric& path,
                       std::string name);

// Serialises every use of OMPL's process-wide seed generator: ompl::RNG::setSeed reseeds the
// generator from which each RNG that OMPL constructs afterwards (planners, samplers, nearest
// neighbour structures, the simplifier) draws its own seed. Hold the lock from setSeed until the
// last OMPL object of the run that draws a seed has been constructed; planners make their
// samplers lazily inside solve(), so PrepareSamplers makes them beforehand. The run itself
// (solve, shortcutting) then uses only its own objects and goes without the lock, so that
// concurrent runs plan in parallel.
std::unique_lock<std::mutex> LockOmplRandomness();
// Makes `count` state samplers of si's space now (the caller holds the lock), and has the space
// hand them out, in order, to whatever asks for one later (a planner inside solve(), a valid
// state sampler); past `count`, new samplers are made as usual (seeded, but not reproducibly).
void PrepareSamplers(const ompl::base::SpaceInformationPtr& si, int count);
// Reseeds OMPL's generator (caller holds the lock); silences OMPL's complaint that seeds were
// already drawn, which is expected: we reseed before every run on purpose.
void SeedOmpl(uint64_t seed);

// Quiets OMPL's informational logging once per process (it would drown the CLI's output).
void QuietOmplLogging();

}  // namespace hgraph::plan_internal
