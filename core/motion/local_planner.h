// The local planner: a straight motion checked with FCL at a resolution, end state first, then in
// bisection order (bad motions fail early). With clearance requested, every sample's clearance
// is recorded, and a stretch between two samples whose clearances exceed how far any robot point
// can move between them is certified free.
#pragma once

#include <atomic>
#include <memory>

#include "core/collision/collision_world.h"
#include "core/motion/motion_checker.h"

namespace hgraph {

struct LocalPlannerOptions {
  // Longest step between two checked samples, as a fraction of the space's MaxExtent()
  // (OMPL's "longest valid segment fraction"). Must be > 0.
  double resolution = 0.01;
};

// Thread safe: one CollisionContext per thread, made on first use. Not copyable.
class LocalPlanner final : public MotionChecker {
 public:
  // Throws InputError("resolution") if options.resolution <= 0 or is not finite.
  LocalPlanner(std::shared_ptr<const CollisionWorld> world, LocalPlannerOptions options = {});
  ~LocalPlanner() override;

  const Space& space() const override;
  EdgeReport CheckEdge(const EdgeCheckRequest& request) const override;
  bool IsValid(const Config& q) const override;
  double Clearance(const Config& q) const override;
  int64_t total_collision_checks() const override;
  int64_t total_distance_queries() const override;

  // Number of samples (including both ends) a motion of this length is checked at.
  int SampleCount(double length) const;
  const CollisionWorld& world() const { return *world_; }

 private:
  struct Impl;
  std::shared_ptr<const CollisionWorld> world_;
  LocalPlannerOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hgraph
