#include "core/search/search.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

#include "core/common/error.h"

namespace hgraph {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Tree {
  std::vector<double> value;
  std::vector<int> via_edge;  // edge into the node on the best path, or -1
};

// A* (Dijkstra without a heuristic) from the start node; `cost` returns infinity for an edge the
// search must not use.
template <typename Cost>
Tree ShortestPaths(const HGraph& graph, const Cost& cost, const std::vector<double>* cost_to_go) {
  Tree tree{std::vector<double>(graph.num_nodes(), kInf), std::vector<int>(graph.num_nodes(), -1)};
  std::vector<char> closed(graph.num_nodes(), 0);
  const auto h = [&](int n) { return cost_to_go != nullptr ? (*cost_to_go)[n] : 0.0; };
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  tree.value[graph.start()] = 0;
  queue.emplace(h(graph.start()), graph.start());
  while (!queue.empty()) {
    const int u = queue.top().second;
    queue.pop();
    if (closed[u]) continue;
    closed[u] = 1;
    if (u == graph.goal()) break;
    const double d = tree.value[u];
    for (const auto& [v, e] : graph.neighbours(u)) {
      if (closed[v]) continue;
      const double c = cost(e);
      if (!(c < kInf)) continue;
      const double nd = d + c;
      if (nd < tree.value[v]) {
        tree.value[v] = nd;
        tree.via_edge[v] = e;
        queue.emplace(nd + h(v), v);
      }
    }
  }
  return tree;
}

// Largest achievable minimum edge width from start to goal (the widest path value), or -1 if the
// goal cannot be reached.
double WidestPathValue(const HGraph& graph, const SearchEdgeFn& edge) {
  std::vector<double> width(graph.num_nodes(), -1.0);
  using Item = std::pair<double, int>;
  std::priority_queue<Item> queue;  // max-heap on width
  width[graph.start()] = kInf;
  queue.emplace(kInf, graph.start());
  while (!queue.empty()) {
    const auto [w, u] = queue.top();
    queue.pop();
    if (w < width[u]) continue;
    if (u == graph.goal()) break;
    for (const auto& [v, e] : graph.neighbours(u)) {
      const double value = edge(e).value;
      if (std::isnan(value)) continue;
      const double nw = std::min(w, value);
      if (nw > width[v]) {
        width[v] = nw;
        queue.emplace(nw, v);
      }
    }
  }
  return width[graph.goal()];
}

SearchResult Extract(const HGraph& graph, const Tree& tree) {
  SearchResult result;
  if (tree.value[graph.goal()] == kInf) return result;
  int node = graph.goal();
  result.nodes.push_back(node);
  while (node != graph.start()) {
    const int e = tree.via_edge[node];
    HGRAPH_CHECK(e >= 0);
    result.edges.push_back(e);
    const HEdge& edge = graph.edge(e);
    node = edge.u == node ? edge.v : edge.u;
    result.nodes.push_back(node);
  }
  std::reverse(result.nodes.begin(), result.nodes.end());
  std::reverse(result.edges.begin(), result.edges.end());
  result.found = true;
  result.value = tree.value[graph.goal()];
  return result;
}

}  // namespace

PathQuality EvaluateEdges(const HGraph& graph, const std::vector<int>& edges, double k) {
  QualityAccumulator accumulator(k);
  for (int e : edges) accumulator.Add(graph.edge(e).report);
  return accumulator.Finish();
}

SearchResult FindBestPath(const HGraph& graph, const Measure& measure, const SearchEdgeFn& edge,
                          const std::vector<double>* cost_to_go) {
  if (measure.combine() == Measure::Combine::kSum) {
    const auto cost = [&edge](int e) {
      const double value = edge(e).value;
      return std::isnan(value) ? kInf : value;
    };
    return Extract(graph, ShortestPaths(graph, cost, cost_to_go));
  }
  // Maximise the bottleneck, then take the shortest path among those that attain it.
  const double width = WidestPathValue(graph, edge);
  if (width < 0) return SearchResult{};
  const auto cost = [&edge, width](int e) {
    const SearchEdge s = edge(e);
    return !std::isnan(s.value) && s.value >= width ? s.length : kInf;
  };
  SearchResult result = Extract(graph, ShortestPaths(graph, cost, nullptr));
  result.value = width;
  return result;
}

SearchResult FindBestPath(const HGraph& graph, const MeasureSpec& spec) {
  const auto measure = Measure::Make(spec);
  const auto edge = [&](int e) {
    const EdgeReport& report = graph.edge(e).report;
    if (report.state != EdgeState::kValid ||
        (measure->needs_clearance() && !report.has_clearance)) {
      return SearchEdge{.value = std::numeric_limits<double>::quiet_NaN(), .length = report.length};
    }
    return SearchEdge{.value = measure->EdgeValue(report), .length = report.length};
  };
  SearchResult result = FindBestPath(graph, *measure, edge);
  if (!result.found) return result;
  result.quality = EvaluateEdges(graph, result.edges, spec.k);
  result.objective = measure->Objective(result.quality);
  return result;
}

}  // namespace hgraph
