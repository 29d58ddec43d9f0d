// FCL collision and clearance queries for a Scene. The only folder that includes FCL headers.
//
// CollisionWorld holds the immutable geometry (OBBRSS BVH meshes, primitives, a broad-phase
// structure over the obstacles) and is shared read-only between threads. Each worker thread
// makes its own CollisionContext, which holds the mutable per-query state (robot body poses).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "core/scene/scene.h"
#include "core/space/clearance_witness.h"
#include "core/space/space.h"

namespace hgraph {

class CollisionContext;

// Immutable after construction; thread safe. Not copyable or movable (contexts point into it).
class CollisionWorld {
 public:
  // Builds the BVHs. Throws InputError if the scene is invalid (see ValidateScene).
  explicit CollisionWorld(std::shared_ptr<const Scene> scene);
  ~CollisionWorld();
  CollisionWorld(const CollisionWorld&) = delete;
  CollisionWorld& operator=(const CollisionWorld&) = delete;

  const Scene& scene() const { return *scene_; }
  const Space& space() const { return scene_->space; }

  // Makes a query context for one thread.
  std::unique_ptr<CollisionContext> MakeContext() const;

  // World pose of robot body i at q.
  Eigen::Isometry3d BodyPose(int body, const Config& q) const;
  // The distance between the witness's two points with the robot at the given body poses
  // (BodyPose of every body), a little above it for rounding: at least the clearance there.
  static double WitnessDistance(const ClearanceWitness& witness,
                                const std::vector<Eigen::Isometry3d>& body_poses);

  // Largest distance from the origin of body i's driving frame to any point of the body: bounds
  // how far a body point moves when the frame turns (core/motion's clearance certificate).
  double BodyRadius(int body) const;
  // The pairs of robot bodies whose distance counts towards clearance (self-collision on, and
  // driven by different components), i < j.
  const std::vector<std::pair<int, int>>& SelfPairs() const;

  // True when CollisionContext::FreeFraction can answer: the robot's bodies and the obstacles
  // are all meshes, and no pair of bodies counts towards clearance.
  bool CanAdvance() const;

  // Approximate memory held by the geometry, in bytes (for cache budgets).
  size_t memory_bytes() const;

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::shared_ptr<const Scene> scene_;
  std::unique_ptr<Impl> impl_;
};

// Per-thread query state. Not thread safe; not copyable.
class CollisionContext {
 public:
  explicit CollisionContext(const CollisionWorld& world);
  ~CollisionContext();
  CollisionContext(const CollisionContext&) = delete;
  CollisionContext& operator=(const CollisionContext&) = delete;

  // True if q is within the bounds and no robot body touches an obstacle (or, with
  // self-collision on, another body). Counts one collision check.
  bool Valid(const Config& q);
  // Minimum distance from the robot to the obstacles (and between bodies with self-collision
  // on); 0 when in collision or out of bounds; +infinity when there is nothing to measure to.
  // Counts one distance query. FCL meshes are surfaces: a body wholly inside a mesh obstacle is
  // neither in collision nor at zero clearance (primitives are solid).
  // With a witness: also where the clearance was found (body -1 when nothing was measured or
  // the robot is in contact or out of bounds).
  double Clearance(const Config& q, ClearanceWitness* witness = nullptr);

  // A lower bound on Clearance(q) that FCL finds with less work: its traversals prune every pair
  // of bounding volumes that could not bring the distance below 1 + rel_err times the nearest
  // found so far (DistanceRequest::rel_err), and start from cap * (1 + rel_err) instead of
  // infinity, so that a robot far from everything costs a few volume tests. Returns L with
  //   min(Clearance(q) / (1 + rel_err), cap) <= L <= min(Clearance(q), cap),
  // and L = 0 exactly when Clearance(q) = 0 (contact or out of bounds): a pair in contact has
  // volumes at distance 0, which are never pruned. With rel_err = 0 it is a threshold query:
  // exactly min(Clearance(q), cap). rel_err >= 0, cap > 0. Counts one distance query.
  double ClearanceLowerBound(const Config& q, double rel_err, double cap);

  // Exactly min(Clearance(q), cap), FCL's traversals started from the smaller of cap and the
  // distance at q between the points of `hint` (an upper bound on the clearance there). A
  // witness from a nearby configuration (the previous sample along a motion) is nearly as near
  // as the nearest pair, so FCL prunes almost every pair of volumes from the start: on the
  // real-size bench meshes a query near obstacles takes about half the time of one started from
  // infinity. On return `hint` holds where the clearance was found, unless nothing nearer than
  // the start was (the result is then cap, or the hint's own points realize it). A hint with
  // body -1 is none. Only in scenes of meshes alone (robot and obstacles): with a primitive in the
  // scene the hint is ignored, since GJK's nearest points are not exact. cap > 0 (may be
  // infinite). Counts one distance query.
  double ClearanceFrom(const Config& q, double cap, ClearanceWitness* hint);

  // How far the straight motion from q towards `to` (Space::Interpolate) is certainly free: a
  // fraction s in [0, limit] such that no robot body touches an obstacle anywhere on the
  // parameters [0, s) of the motion (limit may exceed 1: the motion goes on past `to` at the same
  // rate). Found by direction-aware conservative advancement (free_motion.h): a motion that
  // slides along an obstacle or leaves it goes as far as it is free, where a bound by how far
  // any robot point moves would stop it at the clearance. 0 when a body touches an obstacle at q
  // or q is out of bounds; limit when nothing is found before it. Only where
  // world.CanAdvance(); limit >= 0. Counts one distance query.
  double FreeFraction(const Config& q, const Config& to, double limit);

  // Distance from a world point to the nearest obstacle (mesh surfaces, solid primitives; 0 on or
  // inside a primitive); +infinity without obstacles. The robot plays no part, and no query is
  // counted: core/distance samples the static world with it once per scene, beside the
  // merge's own queries.
  double ObstacleDistance(const Eigen::Vector3d& point);

  int64_t collision_checks() const { return collision_checks_; }
  int64_t distance_queries() const { return distance_queries_; }

 private:
  // The nearest distance below `start` between the placed bodies and the obstacles (and the
  // self pairs), exact (0 in contact), or `start` when nothing is nearer; with `witness`, where
  // it was found when below `start` (unchanged otherwise).
  double Nearest(double start, ClearanceWitness* witness);

  struct Impl;
  const CollisionWorld& world_;
  std::unique_ptr<Impl> impl_;
  int64_t collision_checks_ = 0;
  int64_t distance_queries_ = 0;
};

}  // namespace hgraph
