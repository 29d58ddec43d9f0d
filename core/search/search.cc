#include "core/search/search.h"

#include <algorithm>
#include <functional>
#include <limits>
#include <queue>

#include "core/common/error.h"

namespace hgraph {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

bool Usable(const HEdge& edge) { return edge.report.state == EdgeState::kValid; }

struct Tree {
  std::vector<double> value;
  std::vector<int> via_edge;  // edge into the node on the best path, or -1
};

// Dijkstra from the start node over valid edges; `cost` returns infinity for an unusable edge.
Tree ShortestPaths(const HGraph& graph, const std::function<double(const HEdge&)>& cost) {
  Tree tree{std::vector<double>(graph.num_nodes(), kInf), std::vector<int>(graph.num_nodes(), -1)};
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  tree.value[graph.start()] = 0;
  queue.emplace(0.0, graph.start());
  while (!queue.empty()) {
    const auto [d, u] = queue.top();
    queue.pop();
    if (d > tree.value[u]) continue;
    if (u == graph.goal()) break;
    for (const auto& [v, e] : graph.neighbours(u)) {
      const HEdge& edge = graph.edge(e);
      if (!Usable(edge)) continue;
      const double c = cost(edge);
      if (c == kInf) continue;
      const double nd = d + c;
      if (nd < tree.value[v]) {
        tree.value[v] = nd;
        tree.via_edge[v] = e;
        queue.emplace(nd, v);
      }
    }
  }
  return tree;
}

// Largest achievable minimum edge clearance from start to goal (the widest path value), or -1
// if the goal cannot be reached.
double WidestPathValue(const HGraph& graph) {
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
      const HEdge& edge = graph.edge(e);
      if (!Usable(edge)) continue;
      const double nw = std::min(w, MinClearance(edge.report));
      if (nw > width[v]) {
        width[v] = nw;
        queue.emplace(nw, v);
      }
    }
  }
  return width[graph.goal()];
}

SearchResult Extract(const HGraph& graph, const Tree& tree, const MeasureSpec& spec) {
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
  result.quality = EvaluateEdges(graph, result.edges, spec.k);
  result.objective = Objective(spec, result.quality);
  return result;
}

}  // namespace

PathQuality EvaluateEdges(const HGraph& graph, const std::vector<int>& edges, double k) {
  QualityAccumulator accumulator(k);
  for (int e : edges) accumulator.Add(graph.edge(e).report);
  return accumulator.Finish();
}

SearchResult FindBestPath(const HGraph& graph, const MeasureSpec& spec) {
  switch (spec.type) {
    case MeasureType::kLength:
    case MeasureType::kInverseClearance:
    case MeasureType::kSafeLength: {
      const Tree tree = ShortestPaths(
          graph, [&spec](const HEdge& edge) { return AdditiveEdgeCost(spec, edge.report); });
      return Extract(graph, tree, spec);
    }
    case MeasureType::kBottleneckClearance: {
      // Maximise the bottleneck, then take the shortest path among those that attain it.
      const double width = WidestPathValue(graph);
      if (width < 0) return SearchResult{};
      const Tree tree = ShortestPaths(graph, [width](const HEdge& edge) {
        return MinClearance(edge.report) >= width ? edge.report.length : kInf;
      });
      return Extract(graph, tree, spec);
    }
  }
  return SearchResult{};
}

}  // namespace hgraph
