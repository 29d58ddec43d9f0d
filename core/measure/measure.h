// Quality measures (paper, Appendix) and the edge costs the search uses. An edge's cost is
// always computed from its stored EdgeReport, so one H-Graph serves every measure.
#pragma once

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/motion/motion_checker.h"

namespace hgraph {

// Default exponent k of the integrated inverse clearance (every measure spec, report and flag).
inline constexpr double kDefaultInverseClearanceK = 3.0;

enum class MeasureType {
  kLength,               // path length L
  kInverseClearance,     // integral of cl^-k ds (k = 0 is length)
  kBottleneckClearance,  // maximise the minimum clearance; ties broken by length
  kSafeLength,           // shortest path with clearance >= safety everywhere
};

// "length", "inverse-clearance", "bottleneck-clearance", "safe-length".
const char* MeasureTypeName(MeasureType type);
// Parses the names above; throws InputError naming `field` otherwise.
MeasureType ParseMeasureType(const std::string& name, const std::string& field);

struct MeasureSpec {
  MeasureType type = MeasureType::kLength;
  double k = kDefaultInverseClearanceK;  // inverse clearance exponent, >= 0
  double safety = 0.0;                   // safe-length minimum clearance C, >= 0
};

// Throws InputError naming "measure.k" or "measure.safety" for negative or non-finite values.
void ValidateMeasure(const MeasureSpec& spec);
// True if the measure needs the clearance profile of edges.
bool NeedsClearance(const MeasureSpec& spec);

// Every measure of one path (or edge).
struct PathQuality {
  double length = 0;
  double min_clearance = std::numeric_limits<double>::infinity();
  double avg_clearance = 0;      // integral of cl ds / length (clearance at the point if length 0)
  double inverse_clearance = 0;  // integral of cl^-k ds with the requested k
  double k = kDefaultInverseClearanceK;
  bool has_clearance = false;
};

// Integral of clearance^-k over the edge, by the trapezoid rule on its profile. Infinite if a
// sample has zero clearance. Requires report.has_clearance (or k == 0).
double InverseClearanceIntegral(const EdgeReport& report, double k);
// Integral of clearance over the edge (trapezoid rule).
double ClearanceIntegral(const EdgeReport& report);
// Minimum clearance over the edge's samples.
double MinClearance(const EdgeReport& report);

// Accumulates the quality of a path edge by edge. The sum of additive edge costs equals the
// path's additive measure, so a search and an evaluation agree exactly.
class QualityAccumulator {
 public:
  explicit QualityAccumulator(double k) { quality_.k = k; }
  void Add(const EdgeReport& report);
  PathQuality Finish() const;

 private:
  PathQuality quality_;
  double clearance_integral_ = 0;
  bool all_have_clearance_ = true;
  int edges_ = 0;
};

// What is known of an edge before it is checked: its length (Space::Distance), the clearance at
// its two end configurations (infinity when not computed), how far any robot point moves along
// it (MotionChecker::MotionBound; infinity when unknown), clearances probed at interior
// points of its profile's grid (MotionChecker::ProbeClearance; sorted by t, may be null), and
// upper bounds on the clearance at other grid points.
struct EdgeBoundInput {
  double length = 0;
  double clearance_from = std::numeric_limits<double>::infinity();
  double clearance_to = std::numeric_limits<double>::infinity();
  double motion_bound = std::numeric_limits<double>::infinity();
  const std::vector<ClearanceSample>* interior = nullptr;
  // Upper bounds on the clearance at interior points of the profile's grid (the distances of
  // the known samples' witnesses there, MotionChecker::LowerToWitnesses; sorted by t, may be
  // null). Tighter than the motion bound where the nearest robot point moves less than the
  // farthest. For the measures that use them (Measure::uses_ceilings) in their bound; never in a
  // floor (a proof of clearance).
  const std::vector<ClearanceSample>* ceiling = nullptr;
};

// A quality measure as the search sees it (paper, Appendix): the value of a checked edge, a bound
// on it before the check (so that a lazy search checks only the edges of the paths it would
// take), how values combine along a path, and the objective of a path. Immutable and thread
// safe; not copyable (polymorphic); made by Make.
class Measure {
 public:
  // kSum: a path's cost is the sum of its edges' costs (smaller is better). kBottleneck: a path's
  // width is the minimum of its edges' widths (larger is better), ties broken by length.
  enum class Combine { kSum, kBottleneck };

  // Validates the spec (ValidateMeasure) and returns its measure.
  static std::unique_ptr<const Measure> Make(const MeasureSpec& spec);

  Measure(const Measure&) = delete;
  Measure& operator=(const Measure&) = delete;
  virtual ~Measure() = default;

  const MeasureSpec& spec() const { return spec_; }
  virtual Combine combine() const = 0;
  // True if an edge's value needs its clearance profile (EdgeReport::has_clearance).
  virtual bool needs_clearance() const = 0;
  // True if EdgeBound uses the clearance at the edge's end configurations.
  virtual bool needs_node_clearance() const { return needs_clearance(); }
  // True if EdgeBound uses EdgeBoundInput::ceiling (worth their cost only where the bound
  // follows the clearance all along the edge: inverse clearance).
  virtual bool uses_ceilings() const { return false; }
  // The value of a valid, checked edge (with its profile if needs_clearance): its cost (kSum;
  // infinity = unusable) or its width (kBottleneck: its minimum clearance).
  virtual double EdgeValue(const EdgeReport& report) const = 0;
  // Before the check: a lower bound on the cost (kSum) or an upper bound on the width
  // (kBottleneck) that EdgeValue can return for this edge if it turns out valid.
  virtual double EdgeBound(const EdgeBoundInput& edge) const = 0;
  // Before the check: what the known clearances prove of the edge at worst, or NaN if they
  // prove nothing. kSum: an upper bound on its cost; kBottleneck: a lower bound on its width,
  // positive only when it proves the motion free. An edge whose floor reaches what the search
  // needs of it is settled without a profile (see core/search/search.h).
  virtual double EdgeFloor(const EdgeBoundInput& edge) const {
    (void)edge;
    return std::numeric_limits<double>::quiet_NaN();
  }
  // A clearance that decides an edge's value under this measure, so that an edge proven to keep
  // it (or proven not to) needs no profile: safe length's C. NaN when the value needs the profile.
  virtual double clearance_target() const { return std::numeric_limits<double>::quiet_NaN(); }
  // Cost-to-go lower bound per unit of configuration distance, for A* (kSum; 0 = none).
  virtual double cost_per_distance() const { return 0; }
  // The value the measure optimises, smaller is better: length, inverse clearance, -min
  // clearance (bottleneck), or length (safe length; infinity if below C).
  virtual double Objective(const PathQuality& quality) const = 0;
  // True if quality a is strictly better than b (bottleneck ties broken by length).
  bool Better(const PathQuality& a, const PathQuality& b) const;

 protected:
  explicit Measure(const MeasureSpec& spec) : spec_(spec) {}

 private:
  MeasureSpec spec_;
};

// A lower bound on the clearance all along an unchecked edge (and so on every sample its profile
// would record): clearance changes no faster than robot points move, so between two known
// samples (c0 at t0, c1 at t1) it is at least (c0 + c1 - D (t1 - t0)) / 2, D the motion bound.
// -infinity when an end's clearance or the motion bound is unknown.
double ClearanceFloor(const EdgeBoundInput& edge);
// The same floor over one stretch between two known samples, for motion bound D of the whole
// edge (with the certified planner's slack for rounding); ClearanceFloor is the least of these
// and of the samples.
double StretchFloor(const ClearanceSample& a, const ClearanceSample& b, double motion_bound);
// The clearance at t that one known sample proves at least (with the same slack): c - D |t - t0|.
// Positive: the motion is free at t.
double ReachFloor(const ClearanceSample& a, double t, double motion_bound);

// Cost of a valid edge under an additive measure (length, inverse clearance, safe length; for
// safe length, infinity when the edge's clearance is below `safety`).
double AdditiveEdgeCost(const MeasureSpec& spec, const EdgeReport& report);

// The value the measure optimises, oriented so that smaller is better: length, inverse
// clearance, -min clearance (bottleneck), or length (safe length; infinity if below C).
double Objective(const MeasureSpec& spec, const PathQuality& quality);
// True if quality a is strictly better than b under spec (bottleneck ties broken by length).
bool Better(const MeasureSpec& spec, const PathQuality& a, const PathQuality& b);

}  // namespace hgraph
