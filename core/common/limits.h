// Ranges of every number a request may hold, beyond being finite. They keep derived quantities
// finite and bounded (edge lengths, extents, sample and node counts, gap and inverse-clearance
// costs), so that no value that passes validation can overflow or exhaust the engine. Errors
// name the field and quote the range.
#pragma once

#include <cmath>
#include <sstream>
#include <string>

#include "core/common/error.h"

namespace hgraph::limits {

// Coordinates, bounds, positions, primitive sizes and mesh vertices (after scaling).
inline constexpr double kMaxCoordinate = 1e9;
// Component weights and shape scale factors.
inline constexpr double kMaxWeight = 1e6;
inline constexpr double kMinScale = 1e-6;
// Distances a request names: radius, tolerances, safety, node spacing.
inline constexpr double kMaxDistance = 1e12;
// The local planner's step as a fraction of the space's extent.
inline constexpr double kMinResolution = 1e-6;
inline constexpr double kMaxResolution = 1;
// Collision samples along one edge (length / step).
inline constexpr double kMaxSamplesPerEdge = 1e8;
// Alignment gap costs.
inline constexpr double kMaxGapCost = 1e9;
// The inverse-clearance exponent (clearance^-k).
inline constexpr double kMaxK = 8;
inline constexpr int kMaxPhi = 10000;
inline constexpr int kMaxThreads = 4096;
inline constexpr int kMaxProgressIntervalMs = 3600 * 1000;
inline constexpr double kMaxPlanSeconds = 3600;
// The anytime post-optimization's time budget.
inline constexpr double kMaxOptimizeMs = 3600e3;
// The time a merge that spends its deadline on the post-optimization keeps back for its answer
// (MergeOptions.deadline_margin_ms), and the margin it keeps without one: a tenth of the time
// left, at least this.
inline constexpr double kMaxDeadlineMarginMs = 600e3;
inline constexpr double kMinDefaultDeadlineMarginMs = 50;
// Its restarts from the input paths (each about one post-optimization).
inline constexpr int kMaxOptimizeRestarts = 100000;
// What the post-optimization may add to an H-Graph (its shortcuts' points, and bridges from each
// to the nodes near it, which restarts make dense: ~270 bytes an edge), so that a long budget
// cannot exhaust the memory: it stops once it has added this many nodes or edges.
inline constexpr int kMaxOptimizeNodes = 20000;
inline constexpr int kMaxOptimizeEdges = 250000;
// Nodes an H-Graph may have after subdividing edges (max_node_spacing).
inline constexpr int kMaxNodes = 200000;

inline std::string Num(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// Throws InputError(field) unless lo <= v <= hi (and v is finite).
inline void RequireRange(double v, double lo, double hi, const std::string& field) {
  if (!std::isfinite(v) || v < lo || v > hi) {
    throw InputError(field, "must be in [" + Num(lo) + ", " + Num(hi) + "], got " + Num(v));
  }
}
// Throws InputError(field) unless 0 < v <= hi.
inline void RequirePositiveUpTo(double v, double hi, const std::string& field) {
  if (!std::isfinite(v) || v <= 0 || v > hi) {
    throw InputError(field, "must be in (0, " + Num(hi) + "], got " + Num(v));
  }
}

}  // namespace hgraph::limits
