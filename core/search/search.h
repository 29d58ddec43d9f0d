// Graph search on an H-Graph under a measure: Dijkstra for additive measures, widest path for
// bottleneck clearance (then shortest among the widest), and Dijkstra over edges whose clearance
// is at least C for safe length. Only valid edges are used; clearance-based measures need every
// valid edge to carry its clearance profile.
#pragma once

#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"

namespace hgraph {

struct SearchResult {
  bool found = false;
  std::vector<int> nodes;  // start ... goal
  std::vector<int> edges;  // edge ids between consecutive nodes
  PathQuality quality;
  double objective = 0;  // Objective(spec, quality)
};

// Returns the best start-goal path of `graph` under `spec`, or found == false if the valid
// edges do not connect start and goal (or, for safe length, not with clearance >= C).
SearchResult FindBestPath(const HGraph& graph, const MeasureSpec& spec);

// Quality of a given edge sequence (every edge must be valid; clearance fields are filled only
// if every edge has a profile).
PathQuality EvaluateEdges(const HGraph& graph, const std::vector<int>& edges, double k);

}  // namespace hgraph
