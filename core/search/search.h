// Graph search on an H-Graph under a measure (core/measure): A* / Dijkstra for additive
// measures, widest path for bottleneck clearance (then shortest among the widest), Dijkstra over
// edges whose clearance is at least C for safe length. The search sees each edge through a
// function, so the same search runs on checked edges (their exact values) and, for lazy
// evaluation, on unchecked ones (the measure's bounds).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"

namespace hgraph {

struct SearchResult {
  bool found = false;
  std::vector<int> nodes;  // start ... goal
  std::vector<int> edges;  // edge ids between consecutive nodes
  // The path's value as the search saw it: its cost (kSum) or width (kBottleneck).
  double value = 0;
};

// An edge as the search sees it: its value under the measure (Measure::EdgeValue or EdgeBound;
// NaN for an edge the search must not use) and its length. For a lazy search also what is
// proven of it at worst (Measure::EdgeFloor, or the value when exact; NaN if nothing), and
// whether it was checked valid (a sampled check, without its value yet).
struct SearchEdge {
  double value = 0;
  double length = 0;
  double floor = std::numeric_limits<double>::quiet_NaN();
  bool checked = false;
};
using SearchEdgeFn = std::function<SearchEdge(int edge)>;

// Lazy search: edges are seen through their bounds and checked only where the search needs them;
// a check gives an edge its exact value, or a tighter bound (a refinement in steps, for bounds
// that are cheaper to tighten than to make exact). Returns the same optimum as an eager search of
// the checked graph (Dijkstra, or the widest path then ShortestAmongWidest; the tests hold it
// against one), with far fewer checks. A sum that needs no clearance (length) runs LazySP: the
// shortest path under what is known, then a check of its first edge that is not settled, again
// until the shortest path is settled all along, so that only edges of start-goal paths shorter
// than the answer are ever checked. The other sums, whose bounds cost more to compute and are
// tightened in steps, and the widest search (kBottleneck) run lazy weighted A* (for widths its
// analogue): an edge enters the open list with its bound and is checked when the search would
// settle a node through it (once a node is settled, no other edge into it is checked), up to
// `batch` edges at a time (the most promising ones), so that a parallel `evaluate` keeps several
// threads busy; so does the tie break among the widest.
// `exact(e)` says whether `see(e)` is exact. An edge also settles a node when its floor proves
// what the search needs: its bound (kSum), or a width at least the node's (kBottleneck).
// `evaluate(edges, targets)` checks the edges so that `see` is exact for them afterwards, or at
// least tighter (never looser), and exact after finitely many calls; targets[i] is a value that
// decides edges[i] (kBottleneck: a width; a floor or a bound that reaches past it settles the
// edge), or NaN. `length_to_go`, if not null, holds per node a lower bound on the length to the
// goal: the bottleneck search's tie break (the shortest of the widest paths) runs A* on it. The
// path's edges are all exact, or proven, on return.
using ExactFn = std::function<bool(int edge)>;
using EvaluateFn =
    std::function<void(const std::vector<int>& edges, const std::vector<double>& targets)>;
struct LazySearchStats {
  int64_t evaluations = 0;  // calls of `evaluate`
  int64_t edges_evaluated = 0;
};
SearchResult FindBestPathLazy(const HGraph& graph, const Measure& measure, const SearchEdgeFn& see,
                              const ExactFn& exact, const EvaluateFn& evaluate,
                              const std::vector<double>* cost_to_go,
                              const std::vector<double>* length_to_go, int batch,
                              LazySearchStats* stats);

// The width of the widest start-goal path (the largest minimum edge value; NaN edges unusable),
// or -1 if the goal cannot be reached.
double WidestPathValue(const HGraph& graph, const SearchEdgeFn& edge);

// The bottleneck measures' tie break, the rule of every search that maximises a width: among the
// paths of width `width`, the shortest. `see` seen for that second search: an edge at least
// `width` wide has its length as its value (proven so where its floor is), any other is unusable.
SearchEdgeFn ShortestAmongWidest(SearchEdgeFn see, double width);

// The start-goal path that `via_edge` (per node, the edge into it on the path, or -1) leads back
// along from the goal, with `value` as its SearchResult::value.
SearchResult TracePath(const HGraph& graph, const std::vector<int>& via_edge, double value);

// Quality of a given edge sequence (every edge must be valid; clearance fields are filled only
// if every edge has a profile).
PathQuality EvaluateEdges(const HGraph& graph, const std::vector<int>& edges, double k);

}  // namespace hgraph
