// Graph search on an H-Graph under a measure (core/measure): A* / Dijkstra for additive
// measures, widest path for bottleneck clearance (then shortest among the widest), Dijkstra over
// edges whose clearance is at least C for safe length. The search sees each edge through a
// function, so the same search runs on checked edges (their exact values) and, for lazy
// evaluation, on unchecked ones (the measure's bounds).
#pragma once

#include <functional>
#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"

namespace hgraph {

struct SearchResult {
  bool found = false;
  std::vector<int> nodes;  // start ... goal
  std::vector<int> edges;  // edge ids between consecutive nodes
  PathQuality quality;     // filled by FindBestPath(graph, spec) only
  double objective = 0;    // Objective(spec, quality), likewise
  // The path's value as the search saw it: its cost (kSum) or width (kBottleneck).
  double value = 0;
};

// An edge as the search sees it: its value under the measure (Measure::EdgeValue or EdgeBound;
// NaN for an edge the search must not use) and its length.
struct SearchEdge {
  double value = 0;
  double length = 0;
};
using SearchEdgeFn = std::function<SearchEdge(int edge)>;

// The best start-goal path under `measure`, edges seen through `edge`. `cost_to_go`, if not
// null, holds per node a lower bound on the cost from it to the goal (consistent: an A*
// heuristic; kSum only). found == false if the usable edges do not connect start and goal.
SearchResult FindBestPath(const HGraph& graph, const Measure& measure, const SearchEdgeFn& edge,
                          const std::vector<double>* cost_to_go = nullptr);

// The best path over the checked valid edges (every one with a profile if the measure needs
// clearance), with its quality and objective.
SearchResult FindBestPath(const HGraph& graph, const MeasureSpec& spec);

// Quality of a given edge sequence (every edge must be valid; clearance fields are filled only
// if every edge has a profile).
PathQuality EvaluateEdges(const HGraph& graph, const std::vector<int>& edges, double k);

}  // namespace hgraph
