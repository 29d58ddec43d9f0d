#include "tests/unit/search_oracle.h"

#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

namespace hgraph::testing {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Dijkstra from the start over the edges whose value is a number, to the goal.
SearchResult ShortestPath(const HGraph& graph, const SearchEdgeFn& edge) {
  std::vector<double> cost(graph.num_nodes(), kInf);
  std::vector<int> via_edge(graph.num_nodes(), -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  cost[graph.start()] = 0;
  open.emplace(0.0, graph.start());
  while (!open.empty()) {
    const auto [d, u] = open.top();
    open.pop();
    if (d > cost[u]) continue;
    if (u == graph.goal()) break;
    for (const auto& [v, e] : graph.neighbours(u)) {
      const double c = edge(e).value;
      if (std::isnan(c) || !(c < kInf)) continue;
      if (d + c < cost[v]) {
        cost[v] = d + c;
        via_edge[v] = e;
        open.emplace(cost[v], v);
      }
    }
  }
  if (cost[graph.goal()] == kInf) return SearchResult{};
  return TracePath(graph, via_edge, cost[graph.goal()]);
}

}  // namespace

SearchResult EagerBestPath(const HGraph& graph, const Measure& measure, const SearchEdgeFn& edge) {
  if (measure.combine() == Measure::Combine::kSum) return ShortestPath(graph, edge);
  const double width = WidestPathValue(graph, edge);
  if (width < 0) return SearchResult{};
  SearchResult result = ShortestPath(graph, ShortestAmongWidest(edge, width));
  result.value = width;
  return result;
}

EagerBest EagerBestPath(const HGraph& graph, const MeasureSpec& spec) {
  const auto measure = Measure::Make(spec);
  const auto edge = [&](int e) {
    const EdgeReport& report = graph.edge(e).report;
    if (report.state != EdgeState::kValid || !report.usable() ||
        (measure->needs_clearance() && !report.has_clearance)) {
      return SearchEdge{.value = std::numeric_limits<double>::quiet_NaN(), .length = report.length};
    }
    return SearchEdge{.value = measure->EdgeValue(report), .length = report.length};
  };
  EagerBest best;
  static_cast<SearchResult&>(best) = EagerBestPath(graph, *measure, edge);
  if (!best.found) return best;
  best.quality = EvaluateEdges(graph, best.edges, spec.k);
  best.objective = measure->Objective(best.quality);
  return best;
}

}  // namespace hgraph::testing
