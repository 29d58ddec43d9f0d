// Quality measures (paper, Appendix) and the edge costs the search uses. An edge's cost is
// always computed from its stored EdgeReport, so one H-Graph serves every measure.
#pragma once

#include <limits>
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
  double k = kDefaultInverseClearanceK;       // inverse clearance exponent, >= 0
  double safety = 0.0;  // safe-length minimum clearance C, >= 0
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

// Cost of a valid edge under an additive measure (length, inverse clearance, safe length; for
// safe length, infinity when the edge's clearance is below `safety`).
double AdditiveEdgeCost(const MeasureSpec& spec, const EdgeReport& report);

// The value the measure optimises, oriented so that smaller is better: length, inverse
// clearance, -min clearance (bottleneck), or length (safe length; infinity if below C).
double Objective(const MeasureSpec& spec, const PathQuality& quality);
// True if quality a is strictly better than b under spec (bottleneck ties broken by length).
bool Better(const MeasureSpec& spec, const PathQuality& a, const PathQuality& b);

}  // namespace hgraph
