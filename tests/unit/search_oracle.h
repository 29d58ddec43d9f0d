// The reference the lazy search (core/search) is held against: an eager search that sees every
// edge's value at once. Dijkstra for the sums; for the bottleneck measures the widest path's
// width, then Dijkstra under the engine's one tie break (ShortestAmongWidest). The engine never
// runs it: it checks lazily, also under eager evaluation. Tests and the lazy_limit bench only.
#pragma once

#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"
#include "core/search/search.h"

namespace hgraph::testing {

// The best start-goal path under `measure`, every edge seen through `edge` (NaN: unusable).
// found == false if the usable edges do not connect start and goal.
SearchResult EagerBestPath(const HGraph& graph, const Measure& measure, const SearchEdgeFn& edge);

// A best path over the checked graph, with what it is worth.
struct EagerBest : SearchResult {
  PathQuality quality;
  double objective = 0;  // Objective(spec, quality)
};

// The best path over the checked valid edges (every one with a profile if the measure needs
// clearance; usable ones only), with its quality and objective.
EagerBest EagerBestPath(const HGraph& graph, const MeasureSpec& spec);

}  // namespace hgraph::testing
