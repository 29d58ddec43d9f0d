// The local planner: a straight motion checked with FCL at a resolution, end state first, then in
// bisection order (bad motions fail early). With clearance requested, every sample's clearance
// is recorded, and a stretch between two samples whose clearances exceed how far any robot point
// can move between them is certified free.
//
// The certificate: between samples a and b no point of body i moves farther than
// TranslationDistance + BodyRadius(i) * RotationAngle of its component, so no point of the robot
// moves farther than D(a, b), the sum of that bound over the bodies (which also bounds how much
// the gap between two bodies can shrink). Points move at a steady rate, so at fraction s of the
// stretch the robot is within s * D of where it was at a and within (1 - s) * D of where it is
// at b; if cl(a) + cl(b) > D(a, b), one of the two is less than the clearance there for every s,
// and the whole stretch is collision-free. A stretch that fails the test is halved with one more
// distance query, down to kMaxRefineDepth halvings of a resolution step; a midpoint in collision
// makes the edge invalid (this catches obstacles thinner than the resolution). The refined
// samples join the profile; EdgeReport::certified says whether every stretch passed.
//
// By default (LocalPlannerOptions::direction_bound), where every body and obstacle is a mesh and
// no pair of bodies is checked against each other, certificates advance instead by how far the
// rest of the motion is free along the directions that separate the robot from the obstacles
// (CollisionContext::FreeFraction), and a profile whose stretches do not add up is certified that
// way: a motion sliding along an obstacle is not held to steps of its clearance. It advances from
// both ends (LocalPlannerOptions::advance_from_both_ends), so that a motion that starts next to
// an obstacle and leaves it is certified from its far end. The text below is the certificate
// elsewhere, or with the option off.
//
// With a clearance bound (LocalPlannerOptions::clearance_bound, core/distance), the certificate
// of the modes that keep no profile (kCertified, kCertifiedQuick, kCertifiedOfValid) takes the
// bound's cheap lower bound at each sample first, and FCL's exact distance only where the bound
// cannot decide: a stretch whose bounds do not add up to the motion bound has its ends measured
// exactly before it is halved, conservative advancement measures exactly before it gives up, and
// only an exact clearance ever finds a collision. A certificate that holds with lower bounds holds
// with the exact clearances. Profiles (kClearance, kClearanceOfValid), probes and Clearance()
// stay exact everywhere: measures compute their values from them.
#pragma once

#include <atomic>
#include <memory>

#include "core/collision/collision_world.h"
#include "core/motion/motion_checker.h"

namespace hgraph {

// core/distance's lower bound on clearance; only core/motion sees its definition.
class ClearanceBound;

struct LocalPlannerOptions {
  // Longest step between two checked samples, as a fraction of the space's MaxExtent()
  // (OMPL's "longest valid segment fraction"). Must be > 0.
  double resolution = kDefaultResolution;
  // Asked before the exact distance where a certificate needs only a lower bound (see above);
  // null: exact distances only. From BuildClearanceBound of the same world.
  std::shared_ptr<const ClearanceBound> clearance_bound;
  // Where a certificate needs only a lower bound and the clearance bound above gives none, FCL's
  // distance with this relative error (CollisionContext::ClearanceLowerBound, capped at the
  // clearance that would certify the whole motion from the sample): a bound at least
  // 1 / (1 + rel) of the exact distance, found with fewer triangle pairs. 0: exact distances.
  double certificate_rel_err = 0;
  // Certificates ask FCL for the distance only up to the clearance that would certify the whole
  // rest of the motion from the sample (a threshold query: FCL prunes everything farther from
  // the start instead of from its first triangle pair). Below the threshold the answer is exact;
  // at it, the sample certifies the motion on its own, so the certificate takes exactly the
  // steps and queries exact distances would. False: unbounded exact distances.
  bool certificate_threshold = true;
  // The distance queries of one motion's check (certificates, profiles) start from the nearest
  // points the previous query found (CollisionContext::ClearanceFrom): the same answers, with
  // FCL pruning from a distance near the answer instead of from the threshold or infinity.
  // False: every query starts afresh.
  bool warm_start = true;
  // Certificates advance from each sample as far as the rest of the motion is certainly free,
  // measured along the directions that separate the robot from the obstacles
  // (CollisionContext::FreeFraction), where the world allows it (CollisionWorld::CanAdvance): a
  // motion that slides along an obstacle is not held back to steps of its clearance. A profile
  // whose stretches do not add up is certified this way too. Elsewhere, or false: the two-sided
  // advancement on clearances above, and the profile's own certificate.
  bool direction_bound = true;
  // The advancement along the separating directions runs from both ends of the motion, and
  // certifies it where the two fronts meet: a motion that leaves an obstacle it nearly touches
  // is certified from its other end. The second front runs only where the first stalls, or
  // beside it on a thread the caller's loop leaves idle (EdgeCheckRequest::threads). False:
  // from the start only.
  bool advance_from_both_ends = true;
};

// The clearance bound of a world (a distance field sampled on `threads` threads, 0: all cores,
// and the robot as spheres), or null where none would pay: scenes without meshes or obstacles,
// and worlds too large for a fine enough grid (core/distance/clearance_bound.h). Built once per
// scene and shared by every planner of that world; immutable and thread safe.
std::shared_ptr<const ClearanceBound> BuildClearanceBound(
    const std::shared_ptr<const CollisionWorld>& world, int threads = 0);
// Memory the bound holds, in bytes (for cache budgets).
size_t ClearanceBoundBytes(const ClearanceBound& bound);

// Thread safe: one CollisionContext per thread, made on first use. Not copyable.
class LocalPlanner final : public ClearanceChecker {
 public:
  // Throws InputError("resolution") if options.resolution <= 0 or is not finite.
  LocalPlanner(std::shared_ptr<const CollisionWorld> world, LocalPlannerOptions options = {});
  ~LocalPlanner() override;

  const Space& space() const override;
  EdgeReport CheckEdge(const EdgeCheckRequest& request) const override;
  bool IsValid(const Config& q) const override;
  double Clearance(const Config& q) const override;
  double ClearanceAndWitness(const Config& q, ClearanceWitness* witness) const override;
  void LowerToWitnesses(const Config& from, const Config& to,
                        const std::vector<ClearanceWitness>& witnesses,
                        std::vector<ClearanceSample>* points) const override;
  double MotionBound(const Config& a, const Config& b) const override;
  std::vector<ClearanceSample> ProbeClearance(
      const Config& from, const Config& to, const std::vector<double>& fractions,
      const std::vector<ClearanceSample>& known, ProbeOrder order,
      std::vector<ClearanceWitness>* witnesses = nullptr) const override;
  int ProfileStretches(double length) const override { return SampleCount(length) - 1; }
  int64_t total_collision_checks() const override;
  int64_t total_distance_queries() const override;
  // Lower bounds asked of the clearance bound (each far cheaper than a distance query).
  int64_t total_bound_queries() const;
  bool has_clearance_bound() const { return options_.clearance_bound != nullptr; }

  // Number of samples (including both ends) a motion of this length is checked at.
  int SampleCount(double length) const;
  // Halvings of one resolution step the clearance certificate may ask for.
  static constexpr int kMaxRefineDepth = 8;
  const CollisionWorld& world() const { return *world_; }

 private:
  struct Impl;
  std::shared_ptr<const CollisionWorld> world_;
  LocalPlannerOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hgraph
