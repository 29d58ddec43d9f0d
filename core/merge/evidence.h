// What a merge knows of its H-Graph beyond the edges' check reports: per node and per edge
// facts that the lazy evaluation gathers (clearances, probes, bounds). Grown in one place
// (Grow) whenever the H-Graph grows, and cut back (Truncate) when a query drops its overlay
// (the post-optimization's nodes and edges), so that the arrays always match the graph.
// Everything here is a fact about a configuration or a motion: it changes what a query costs,
// never what it answers. Copyable and movable; not thread safe for writes, except that distinct
// edges' entries may be written by distinct threads.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/motion/motion_checker.h"
#include "core/space/clearance_witness.h"
#include "core/space/space.h"

namespace hgraph {

// Where an edge's ceiling bounds its clearance: at most kCeilingPoints points of the grid of a
// profile of `stretches` stretches (t = k / stretches), evenly spread (all of them on an edge of
// up to kCeilingPoints + 1 stretches), each once, interior only, in order of t. Calls f(t) for
// each. The snapshot (snapshot.h) stores a ceiling on this grid as its clearances alone.
// Wrench inverse clearance (k = 3, all-pairs, spacing 1): 16, 32, 64 and every grid point take
// 29347, 24442, 18622 and 17228 distance queries; past 64 the ceilings cost more time than the
// queries they save.
inline constexpr int kCeilingPoints = 64;
template <typename F>
void ForEachCeilingPoint(int stretches, const F& f) {
  const int64_t points = std::min(stretches - 1, kCeilingPoints);
  int64_t last = 0;
  for (int64_t i = 1; i <= points; ++i) {
    // The nearest integer to i * stretches / (points + 1), halves up (std::lround of the
    // quotient, whose double is exact enough for a divisor of at most kCeilingPoints + 1).
    const int64_t k = (2 * i * stretches + points + 1) / (2 * (points + 1));
    if (k <= last || k >= stretches) continue;
    last = k;
    f(static_cast<double>(k) / stretches);
  }
}

struct EdgeEvidence {
  // Per node.
  std::vector<double> goal_distance;           // Space::Distance to the goal
  std::vector<double> node_clearance;          // clearance, NaN until needed
  std::vector<char> node_valid;                // 1 once an edge check found it valid
  std::vector<ClearanceWitness> node_witness;  // where its clearance was found
  // Per edge.
  std::vector<double> edge_length;   // Space::Distance of its ends
  std::vector<double> motion_bound;  // MotionChecker::MotionBound, NaN until needed
  // For measures that need clearance: the clearances probed on the profile's grid before the
  // profile itself (MotionChecker::ProbeClearance), and how many probe rounds ran.
  std::vector<std::vector<ClearanceSample>> probes;
  std::vector<int8_t> probe_rounds;
  std::vector<int8_t> scanned;  // the contact scan ran
  // Upper bounds on its clearance at points of its profile's grid, from its ends' witnesses
  // (EdgeBoundInput::ceiling), once both ends have one.
  std::vector<std::vector<ClearanceSample>> ceiling;
  std::vector<int8_t> ceiling_done;
  std::vector<std::vector<ClearanceWitness>> probe_witness;  // its probes' witnesses

  int num_nodes() const { return static_cast<int>(goal_distance.size()); }
  int num_edges() const { return static_cast<int>(edge_length.size()); }
  // Extends every array to the graph's nodes and edges, the new entries unknown.
  void Grow(const HGraph& graph, const Space& space);
  // Keeps the first `nodes` nodes' and `edges` edges' entries only.
  void Truncate(int nodes, int edges);
  size_t memory_bytes() const;
};

}  // namespace hgraph
