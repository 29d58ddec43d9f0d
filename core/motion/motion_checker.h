// The local planner's interface, as the H-Graph and the search see it (never FCL).
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "core/common/progress.h"
#include "core/space/clearance_witness.h"
#include "core/space/space.h"

namespace hgraph {

// State of an edge in the H-Graph. Unchecked edges exist for the lazy variant, which checks an
// edge only when a search wants it.
enum class EdgeState { kUnchecked, kValid, kInvalid };

// Clearance at parameter t in [0, 1] along a straight motion.
struct ClearanceSample {
  double t = 0;
  double clearance = 0;
};

// What conservative advancement (EdgeProof::kCertificate's first stage) concluded on a motion:
// not run, it certified the motion, or it stalled (its steps would shrink below the profile's
// finest refinement) on a motion valid at its samples. A fact of the motion alone.
enum class Advancement : int8_t { kUnknown, kCertified, kStalled };

// What the local planner found about one straight motion. Stored on the H-Graph edge, so that
// any measure can be evaluated later without checking again.
struct EdgeReport {
  EdgeState state = EdgeState::kUnchecked;
  double length = 0;  // Space::Distance(from, to)
  // Clearance at the checked samples, sorted by t, including t = 0 and t = 1. Present only when
  // the check was asked for clearance (has_clearance) and the motion is valid.
  bool has_clearance = false;
  std::vector<ClearanceSample> profile;
  double invalid_at = -1;  // parameter of the first invalid sample found, or -1
  // With clearance: true when every stretch between consecutive profile samples is proven free,
  // because the two clearances add up to more than any robot point can move along the stretch.
  // False means the motion was only checked at the samples (see core/motion/local_planner.h).
  bool certified = false;
  Advancement advancement = Advancement::kUnknown;
  int64_t collision_checks = 0;
  int64_t distance_queries = 0;

  // Whether a path may use the motion: not found invalid, and not profiled without a certificate
  // (a motion that grazes an obstacle closer than the finest refinement can prove free is
  // refused, so that every merged path is certified).
  bool usable() const { return state != EdgeState::kInvalid && !(has_clearance && !certified); }
  // Whether a path that takes motions valid at their samples (a sampled merge, OMPL's discrete
  // motion validator) may use the motion: not found invalid. A profile without a certificate
  // passed its samples, so it is usable here.
  bool usable_at_samples() const { return state != EdgeState::kInvalid; }
};

// Default local-planner resolution: the longest step between two checked samples as a fraction
// of the space's MaxExtent() (OMPL's "longest valid segment fraction" default). Every default
// resolution (the local planner's, a scene's unset one, OMPL's in core/plan) is this one.
inline constexpr double kDefaultResolution = 0.01;

// What a check of one motion must establish (EdgeCheckRequest::proof).
enum class EdgeProof {
  // Validity at the resolution's samples only (OMPL's discrete motion validator).
  kSamples,
  // Validity, with the motion also proven free between its samples but no profile recorded,
  // for a caller that wants the merge's guarantee without clearances (a planner's motion
  // validator). Conservative advancement: from a point with clearance c the robot moves freely
  // while no point of it moves c, so one distance query clears a long stretch in open space.
  // Where the steps would shrink below the profile's finest refinement, the profile's check
  // (kProfile) runs instead, so the answer is the one kProfile would give. Sets
  // report.certified.
  kCertificate,
  // As kCertificate, except where conservative advancement stalls: the answer is then "valid,
  // not certified" at once (the samples at the resolution passed), without the profile
  // kCertificate falls back to. For a caller that takes only proven motions and has other
  // candidates to try (the post-optimization's shortcuts): a motion that grazes an obstacle
  // costs a few distance queries instead of a profile. It certifies a motion, or finds it in
  // collision, only where kCertificate's samples and advancement do.
  kCertificateOrGiveUp,
  // Validity and the clearance profile with its certificate (core/motion/local_planner.h).
  kProfile,
};

// What the caller already knows of the motion, from earlier checks at this checker. A check
// skips what is known; it never trusts a guess (every field is a fact some check found).
struct EdgeKnown {
  // This end passed a collision check: its check, the first of the samples, is skipped.
  bool from_valid = false;
  bool to_valid = false;
  // The whole motion passed the sampled check at this checker's resolution (kSamples): the
  // samples are skipped, and the proof starts from them (a lazy search's edge on the path it
  // found, a stored edge re-checked for its profile). A profile's clearances find any
  // collision on their own; a certificate finds one where a distance query is in contact.
  bool samples_valid = false;
  // Clearances at points of the profile's grid (ProbeClearance's samples, the clearance of an
  // end at t = 0 or 1), sorted by t; a profile takes them instead of querying again. May be null.
  const std::vector<ClearanceSample>* clearances = nullptr;
};

struct EdgeCheckRequest {
  const Config* from = nullptr;
  const Config* to = nullptr;
  EdgeProof proof = EdgeProof::kSamples;
  EdgeKnown known;
  // Stops a long check (an edge of many samples at a fine resolution) between samples: CheckEdge
  // throws the token's error (ThrowIfStopped) once it is stopped. May be null.
  const CancelToken* cancel = nullptr;
  // Threads of the caller's loop that this check may share when they fall idle (its samples, the
  // second front of a certificate, LocalPlannerOptions::direction_bound); 1: the calling thread
  // alone. The report is the same either way, but for what it counts.
  int threads = 1;
};

// How ProbeClearance takes its samples: a distance query at each point, or first a collision
// check (about a tenth of a distance query on meshes), which answers "in contact" (clearance 0)
// on its own and ends the probe there: the motion is invalid, and its other points are not
// needed. For a caller that expects contact often (lazy evaluation probing bridge candidates).
// kCollisionOnly takes no distance query at all: it checks the points in the order given and
// returns only the first in contact (clearance 0), or nothing; a cheap scan for contact before a
// caller pays for clearances.
enum class ProbeOrder { kDistanceOnly, kCollisionFirst, kCollisionOnly };

// Checks straight motions. Implementations must be thread safe: the H-Graph calls CheckEdge
// from many worker threads at once. Not copyable (polymorphic base).
class MotionChecker {
 public:
  MotionChecker() = default;
  MotionChecker(const MotionChecker&) = delete;
  MotionChecker& operator=(const MotionChecker&) = delete;
  virtual ~MotionChecker() = default;

  virtual const Space& space() const = 0;
  virtual EdgeReport CheckEdge(const EdgeCheckRequest& request) const = 0;
  virtual bool IsValid(const Config& q) const = 0;
  virtual double Clearance(const Config& q) const = 0;
  // Totals over every query this checker ran so far (for progress and stats).
  virtual int64_t total_collision_checks() const = 0;
  virtual int64_t total_distance_queries() const = 0;
};

// A motion checker that also answers what the merge's lazy evaluation asks of clearance
// (core/merge/edge_evaluator.h): witnesses, motion bounds, probes on the profile's grid. The
// merge requires one; planning and CheckPaths take any MotionChecker. Every method is required,
// so that a wrapper cannot forget one and silently answer "nothing known".
class ClearanceChecker : public MotionChecker {
 public:
  // The clearance at q and where it was found (a witness with body -1 when the checker cannot
  // say). Counts one distance query.
  virtual double ClearanceAndWitness(const Config& q, ClearanceWitness* witness) const = 0;
  // Lowers the clearance of each point (at its t along the straight motion from `from` to `to`)
  // to the distance between the points of each witness there (ClearanceWitness), which bounds
  // the clearance at t from above. Lazy evaluation bounds an unchecked edge's clearance with the
  // witnesses of its ends and probes, tighter than the motion bound alone. Witnesses with
  // body -1 are skipped.
  virtual void LowerToWitnesses(const Config& from, const Config& to,
                                const std::vector<ClearanceWitness>& witnesses,
                                std::vector<ClearanceSample>* points) const = 0;
  // An upper bound on how far any point of the robot moves along the straight motion from a to
  // b (and so on how much the clearance can change along it: clearance is 1-Lipschitz in that
  // displacement). Lazy evaluation bounds an unchecked edge's clearance with it. Infinity when
  // the checker cannot say.
  virtual double MotionBound(const Config& a, const Config& b) const = 0;
  // Clearances at points of the grid a clearance profile of the motion from `from` to `to`
  // samples (EdgeProof::kProfile), nearest to the given fractions of the way: interior points only,
  // none whose t is in `known`, each once, sorted by t. They are the very samples the profile would
  // record there, so that a bound built on them holds for the profile. Lazy evaluation tightens
  // an edge's bound with them before it pays for the whole profile. Empty when no such point
  // is left. Counts a distance query per sample, and
  // with kCollisionFirst a collision check per sample (kCollisionOnly: see ProbeOrder). With
  // `witnesses`, appends where each measured clearance was found (those the checker knows).
  virtual std::vector<ClearanceSample> ProbeClearance(
      const Config& from, const Config& to, const std::vector<double>& fractions,
      const std::vector<ClearanceSample>& known, ProbeOrder order,
      std::vector<ClearanceWitness>* witnesses = nullptr) const = 0;
  // The number of stretches a clearance profile of a motion of this length samples (its grid
  // has that many + 1 points, at t = k / stretches).
  virtual int ProfileStretches(double length) const = 0;
};

}  // namespace hgraph
