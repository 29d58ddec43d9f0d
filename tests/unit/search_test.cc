// Search on small H-Graphs whose edge reports are set by hand: the eager reference search
// (search_oracle.h) against exhaustive enumeration of every simple start-goal path, and the lazy
// search against the reference.
#include "core/search/search.h"

#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/path/path.h"
#include "core/search/glance.h"
#include "tests/unit/search_oracle.h"

namespace hgraph {
namespace {

using testing::EagerBest;
using testing::EagerBestPath;

Space Plane() { return Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)); }

Config P(double x, double y) { return Eigen::Vector2d(x, y); }

// Fills a valid, certified report for an edge with a clearance profile of `samples` points.
void SetReport(HGraph& graph, const Space& space, int e, std::vector<double> clearances) {
  HEdge& edge = graph.mutable_edge(e);
  edge.report.state = EdgeState::kValid;
  edge.report.length = space.Distance(graph.node(edge.u).q, graph.node(edge.v).q);
  edge.report.has_clearance = true;
  edge.report.certified = true;
  edge.report.profile.clear();
  for (size_t s = 0; s < clearances.size(); ++s) {
    edge.report.profile.push_back(
        {static_cast<double>(s) / (clearances.size() - 1), clearances[s]});
  }
}

// Every simple start-goal path over valid edges, as edge lists.
std::vector<std::vector<int>> AllPaths(const HGraph& graph) {
  std::vector<std::vector<int>> out;
  std::vector<int> edges;
  std::vector<bool> seen(graph.num_nodes(), false);
  std::function<void(int)> walk = [&](int u) {
    if (u == graph.goal()) {
      out.push_back(edges);
      return;
    }
    seen[u] = true;
    for (const auto& [v, e] : graph.neighbours(u)) {
      if (seen[v] || graph.edge(e).report.state != EdgeState::kValid) continue;
      edges.push_back(e);
      walk(v);
      edges.pop_back();
    }
    seen[u] = false;
  };
  walk(graph.start());
  return out;
}

// Three random paths from (0,0) to (10,10) with middle[p] random waypoints each, bridges between
// any two nodes with probability `bridges`, 30% of them invalid, the other edges valid with a
// random clearance profile of three samples.
HGraph RandomHGraph(const Space& space, const std::vector<int>& middle, double bridges,
                    std::mt19937_64& rng) {
  std::uniform_real_distribution<double> coord(0, 10), clearance(0.05, 2.0), coin(0, 1);
  std::vector<InputPath> paths;
  for (size_t p = 0; p < middle.size(); ++p) {
    InputPath path{.name = "p" + std::to_string(p)};
    path.waypoints.push_back(P(0, 0));
    for (int k = 0; k < middle[p]; ++k) path.waypoints.push_back(P(coord(rng), coord(rng)));
    path.waypoints.push_back(P(10, 10));
    paths.push_back(path);
  }
  HGraph graph(space, paths, 1e-9);
  for (int u = 0; u < graph.num_nodes(); ++u) {
    for (int v = u + 1; v < graph.num_nodes(); ++v) {
      if (coin(rng) < bridges) graph.AddEdge(u, v, false);
    }
  }
  for (int e = 0; e < graph.num_edges(); ++e) {
    if (!graph.edge(e).input && coin(rng) < 0.3) {
      graph.mutable_edge(e).report.state = EdgeState::kInvalid;
      continue;
    }
    SetReport(graph, space, e, {clearance(rng), clearance(rng), clearance(rng)});
  }
  return graph;
}

class SearchPropertyTest : public ::testing::TestWithParam<int> {};

TEST_P(SearchPropertyTest, EveryMeasureFindsTheExhaustiveOptimum) {
  std::mt19937_64 rng(GetParam());
  const Space space = Plane();
  HGraph graph = RandomHGraph(space, {1, 2, 1}, 0.4, rng);
  const std::vector<std::vector<int>> all = AllPaths(graph);
  ASSERT_FALSE(all.empty());
  for (const MeasureSpec spec : {MeasureSpec{.type = MeasureType::kLength},
                                 MeasureSpec{.type = MeasureType::kInverseClearance, .k = 3},
                                 MeasureSpec{.type = MeasureType::kInverseClearance, .k = 0.25},
                                 MeasureSpec{.type = MeasureType::kBottleneckClearance},
                                 MeasureSpec{.type = MeasureType::kSafeLength, .safety = 0.3}}) {
    PathQuality best;
    bool any = false;
    for (const auto& edges : all) {
      const PathQuality q = EvaluateEdges(graph, edges, spec.k);
      if (Objective(spec, q) == std::numeric_limits<double>::infinity()) continue;
      if (!any || Better(spec, q, best)) best = q;
      any = true;
    }
    const EagerBest found = EagerBestPath(graph, spec);
    ASSERT_EQ(found.found, any) << MeasureTypeName(spec.type);
    if (!any) continue;
    EXPECT_EQ(found.nodes.front(), graph.start());
    EXPECT_EQ(found.nodes.back(), graph.goal());
    EXPECT_NEAR(Objective(spec, found.quality), Objective(spec, best), 1e-9)
        << MeasureTypeName(spec.type);
    if (spec.type == MeasureType::kBottleneckClearance) {
      EXPECT_NEAR(found.quality.length, best.length, 1e-9) << "ties broken by length";
    }
  }
}

// The lazy search on edges seen through bounds and floors, as lazy evaluation sees them: a check
// with a target proves the edge keeps it or lowers its bound below it, and only a target at the
// bound (or none) makes the edge exact. It finds the exhaustive optimum and leaves edges
// decided without their exact values.
TEST_P(SearchPropertyTest, LazySearchWithFloorsFindsTheExhaustiveOptimum) {
  std::mt19937_64 rng(GetParam());
  std::uniform_real_distribution<double> coin(0, 1);
  const Space space = Plane();
  HGraph graph = RandomHGraph(space, {2, 3, 4}, 0.5, rng);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  int decided_inexact = 0;
  for (const MeasureSpec spec : {MeasureSpec{.type = MeasureType::kBottleneckClearance},
                                 MeasureSpec{.type = MeasureType::kSafeLength, .safety = 0.3}}) {
    const auto measure = Measure::Make(spec);
    const bool widest = measure->combine() == Measure::Combine::kBottleneck;
    // Per edge: its width (the profile's minimum), a bound above it and a floor below it.
    const int n = graph.num_edges();
    std::vector<double> width(n), bound(n), floor(n);
    std::vector<char> exact(n, 0);
    for (int e = 0; e < n; ++e) {
      if (graph.edge(e).report.state != EdgeState::kValid) continue;
      width[e] = MinClearance(graph.edge(e).report);
      bound[e] = width[e] + coin(rng);
      floor[e] = width[e] * coin(rng);
    }
    const SearchEdgeFn see = [&](int e) {
      const double length = graph.edge(e).report.length;
      if (graph.edge(e).report.state != EdgeState::kValid) {
        return SearchEdge{.value = nan, .length = length};
      }
      const double lo = exact[e] ? width[e] : floor[e];
      const double hi = exact[e] ? width[e] : bound[e];
      if (widest) return SearchEdge{.value = hi, .length = length, .floor = lo > 0 ? lo : nan};
      return SearchEdge{.value = hi >= spec.safety ? length : inf,
                        .length = length,
                        .floor = lo >= spec.safety ? length : nan};
    };
    const ExactFn is_exact = [&](int e) {
      return graph.edge(e).report.state != EdgeState::kValid || exact[e];
    };
    const EvaluateFn evaluate = [&](const std::vector<int>& edges,
                                    const std::vector<double>& targets) {
      ASSERT_EQ(edges.size(), targets.size());
      for (size_t k = 0; k < edges.size(); ++k) {
        const int e = edges[k];
        const double t = targets[k];
        if (!(t > 0) || t >= bound[e]) {
          exact[e] = 1;
        } else if (width[e] >= t) {
          floor[e] = std::max(floor[e], t);
        } else {
          bound[e] = width[e] + 0.5 * (t - width[e]);
        }
      }
    };
    std::vector<double> to_go(graph.num_nodes());
    for (int v = 0; v < graph.num_nodes(); ++v) {
      to_go[v] = space.Distance(graph.node(v).q, graph.node(graph.goal()).q);
    }
    const SearchResult lazy = FindBestPathLazy(graph, *measure, see, is_exact, evaluate,
                                               widest ? nullptr : &to_go, &to_go, 3, nullptr);
    const EagerBest eager = EagerBestPath(graph, spec);
    ASSERT_EQ(lazy.found, eager.found) << MeasureTypeName(spec.type);
    if (!eager.found) continue;
    const PathQuality q = EvaluateEdges(graph, lazy.edges, spec.k);
    EXPECT_NEAR(Objective(spec, q), eager.objective, 1e-9) << MeasureTypeName(spec.type);
    EXPECT_NEAR(q.length, eager.quality.length, 1e-9) << MeasureTypeName(spec.type);
    for (int e = 0; e < n; ++e) {
      if (graph.edge(e).report.state == EdgeState::kValid && !exact[e] && floor[e] > 0 &&
          bound[e] > floor[e]) {
        ++decided_inexact;
      }
    }
  }
  EXPECT_GT(decided_inexact, 0);
}

// A sum search that glances at an edge first (core/search/glance.h) settles, checks and returns
// what it would without: every batch of checks the same, in the same order, and the same path;
// and it never sees some of the edges it glanced at. The glances are random fractions of the
// bounds, some equal to them (ties with other entries).
TEST_P(SearchPropertyTest, GlancesChangeNeitherTheChecksNorThePath) {
  std::mt19937_64 rng(GetParam());
  std::uniform_real_distribution<double> coin(0, 1);
  const Space space = Plane();
  HGraph graph = RandomHGraph(space, {3, 4, 5}, 0.6, rng);
  const int n = graph.num_edges();
  std::vector<double> bound(n), glance(n);
  for (int e = 0; e < n; ++e) {
    bound[e] = coin(rng);
    glance[e] = coin(rng) < 0.2 ? 1.0 : coin(rng);
  }
  std::vector<double> to_go(graph.num_nodes());
  for (int v = 0; v < graph.num_nodes(); ++v) {
    to_go[v] = space.Distance(graph.node(v).q, graph.node(graph.goal()).q);
  }
  int64_t glanced = 0;
  int64_t refined = 0;
  for (const MeasureSpec spec : {MeasureSpec{.type = MeasureType::kInverseClearance, .k = 3},
                                 MeasureSpec{.type = MeasureType::kLength}}) {
    const auto measure = Measure::Make(spec);
    const bool length = spec.type == MeasureType::kLength;
    struct Run {
      SearchResult found;
      std::vector<std::vector<int>> batches;
      int64_t seen = 0;
    };
    const auto search = [&](bool glancing) {
      Run run;
      std::vector<char> exact(n, 0);
      const SearchEdgeFn see = [&](int e) {
        ++run.seen;
        const EdgeReport& report = graph.edge(e).report;
        if (report.state != EdgeState::kValid)
          return SearchEdge{.value = std::numeric_limits<double>::quiet_NaN(), .length = 1};
        const double value = measure->EdgeValue(report);
        return SearchEdge{.value = exact[e] ? value : value * bound[e], .length = report.length};
      };
      const ExactFn is_exact = [&](int e) {
        return graph.edge(e).report.state != EdgeState::kValid || exact[e];
      };
      const EvaluateFn evaluate = [&](const std::vector<int>& edges, const std::vector<double>&) {
        run.batches.push_back(edges);
        for (int e : edges) exact[e] = 1;
      };
      const GlanceFn glancer = [&](int e) -> std::optional<double> {
        const EdgeReport& report = graph.edge(e).report;
        if (is_exact(e)) return std::nullopt;
        return measure->EdgeValue(report) * bound[e] * glance[e];
      };
      GlanceStats stats;
      const std::vector<double>* cost_to_go = length ? &to_go : nullptr;
      run.found = glancing ? FindBestPathLazy(graph, *measure, see, is_exact, evaluate, cost_to_go,
                                              &to_go, 3, nullptr, glancer, &stats)
                           : FindBestPathLazy(graph, *measure, see, is_exact, evaluate, cost_to_go,
                                              &to_go, 3, nullptr);
      glanced += stats.glanced;
      refined += stats.refined;
      return run;
    };
    const Run plain = search(false);
    const Run glancing = search(true);
    ASSERT_EQ(plain.found.found, glancing.found.found) << MeasureTypeName(spec.type);
    EXPECT_EQ(plain.found.nodes, glancing.found.nodes) << MeasureTypeName(spec.type);
    EXPECT_EQ(plain.found.edges, glancing.found.edges) << MeasureTypeName(spec.type);
    EXPECT_EQ(plain.found.value, glancing.found.value) << MeasureTypeName(spec.type);
    EXPECT_EQ(plain.batches, glancing.batches) << MeasureTypeName(spec.type);
    EXPECT_LE(glancing.seen, plain.seen) << MeasureTypeName(spec.type);
  }
  EXPECT_GT(glanced, 0);
  EXPECT_LT(refined, glanced);
}

INSTANTIATE_TEST_SUITE_P(Seeds, SearchPropertyTest, ::testing::Range(1, 41));

// A sum's lazy search checks edges of start-goal routes shorter than the answer only: a bridge
// that would shorten the path is checked (and found invalid), a short edge into a dead end is
// not, though A* would settle the dead end (its key is below the answer's) and check it.
TEST(SearchTest, LazySumSearchChecksOnlyEdgesOfShorterRoutes) {
  const Space space = Plane();
  HGraph graph(space, {InputPath{.waypoints = {P(0, 0), P(5, 4), P(10, 0)}}}, 0);
  for (int e : graph.path_edges(0)) SetReport(graph, space, e, {1, 1});
  const int bridge = graph.AddEdge(graph.start(), graph.goal(), false);
  const int dead_end = graph.AddNode(P(4, -1));
  const int into_dead_end = graph.AddEdge(graph.start(), dead_end, false);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const SearchEdgeFn see = [&](int e) {
    const EdgeReport& report = graph.edge(e).report;
    const double length =
        space.Distance(graph.node(graph.edge(e).u).q, graph.node(graph.edge(e).v).q);
    if (report.state == EdgeState::kInvalid) return SearchEdge{.value = nan, .length = length};
    return SearchEdge{.value = length,
                      .length = length,
                      .floor = report.state == EdgeState::kValid ? length : nan};
  };
  const ExactFn exact = [&](int e) { return graph.edge(e).report.state != EdgeState::kUnchecked; };
  std::vector<int> checked;
  const EvaluateFn evaluate = [&](const std::vector<int>& edges, const std::vector<double>&) {
    for (int e : edges) {
      checked.push_back(e);
      if (e == bridge) {
        graph.mutable_edge(e).report.state = EdgeState::kInvalid;
      } else {
        SetReport(graph, space, e, {1, 1});
      }
    }
  };
  std::vector<double> to_go(graph.num_nodes());
  for (int v = 0; v < graph.num_nodes(); ++v) {
    to_go[v] = space.Distance(graph.node(v).q, graph.node(graph.goal()).q);
  }
  // The dead end's key (its distance from the start plus its distance to the goal) is below the
  // input path's length, the answer.
  ASSERT_LT(space.Distance(P(0, 0), P(4, -1)) + to_go[dead_end], PathLength(space, graph.path(0)));
  const auto measure = Measure::Make(MeasureSpec{.type = MeasureType::kLength});
  const SearchResult lazy =
      FindBestPathLazy(graph, *measure, see, exact, evaluate, &to_go, nullptr, 8, nullptr);
  ASSERT_TRUE(lazy.found);
  EXPECT_EQ(lazy.edges, graph.path_edges(0));
  EXPECT_EQ(checked, std::vector<int>{bridge});
  EXPECT_EQ(graph.edge(into_dead_end).report.state, EdgeState::kUnchecked);
}

// A long input whose edges are all valid is checked in growing batches along one search's path
// (each check leaves the path the shortest), not one search per edge: a 20,000-edge input takes
// a few hundred evaluations, and every edge is checked once.
TEST(SearchTest, LazySumSearchChecksALongValidInputInGrowingBatches) {
  const Space space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(20000, 10));
  InputPath input;
  for (int i = 0; i <= 20000; ++i) input.waypoints.push_back(P(i, i % 2 == 0 ? 0 : 1));
  HGraph graph(space, {input}, 0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const SearchEdgeFn see = [&](int e) {
    const double length = graph.edge(e).report.length;
    const bool valid = graph.edge(e).report.state == EdgeState::kValid;
    return SearchEdge{.value = length, .length = length, .floor = valid ? length : nan};
  };
  for (int e = 0; e < graph.num_edges(); ++e) {
    HEdge& edge = graph.mutable_edge(e);
    edge.report.length = space.Distance(graph.node(edge.u).q, graph.node(edge.v).q);
  }
  const ExactFn exact = [&](int e) { return graph.edge(e).report.state != EdgeState::kUnchecked; };
  int64_t checked = 0;
  const EvaluateFn evaluate = [&](const std::vector<int>& edges, const std::vector<double>&) {
    for (int e : edges) {
      EXPECT_EQ(graph.edge(e).report.state, EdgeState::kUnchecked) << "edge " << e;
      graph.mutable_edge(e).report.state = EdgeState::kValid;
      ++checked;
    }
  };
  const auto measure = Measure::Make(MeasureSpec{.type = MeasureType::kLength});
  LazySearchStats stats;
  const SearchResult lazy =
      FindBestPathLazy(graph, *measure, see, exact, evaluate, nullptr, nullptr, 8, &stats);
  ASSERT_TRUE(lazy.found);
  EXPECT_EQ(lazy.edges, graph.path_edges(0));
  EXPECT_EQ(checked, graph.num_edges());
  EXPECT_LT(stats.evaluations, 1000);
}

// On a large H-Graph (4000 nodes) where 40% of the bridges are in collision, each one found
// costing a search of its own, the lazy sum search returns the eager search's path over the
// edges that are valid.
TEST(SearchTest, LazySumSearchWithManyMotionsInCollisionFindsTheEagerPath) {
  const Space space = Plane();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> coord(0, 10), coin(0, 1);
  HGraph graph(space, {InputPath{.waypoints = {P(0, 0), P(0, 10), P(10, 10)}}}, 0);
  for (int e : graph.path_edges(0)) SetReport(graph, space, e, {1, 1});
  const int inputs = graph.num_edges();
  for (int k = 0; k < 4000; ++k) graph.AddNode(P(coord(rng), coord(rng)));
  for (int u = 0; u < graph.num_nodes(); ++u) {
    for (int v = u + 1; v < graph.num_nodes(); ++v) {
      if (space.Distance(graph.node(u).q, graph.node(v).q) < 0.4) graph.AddEdge(u, v, false);
    }
  }
  std::vector<char> free(graph.num_edges(), 1);
  for (int e = inputs; e < graph.num_edges(); ++e) {
    free[e] = coin(rng) < 0.6 ? 1 : 0;
    HEdge& edge = graph.mutable_edge(e);
    edge.report.length = space.Distance(graph.node(edge.u).q, graph.node(edge.v).q);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const SearchEdgeFn see = [&](int e) {
    const EdgeReport& report = graph.edge(e).report;
    if (report.state == EdgeState::kInvalid) {
      return SearchEdge{.value = nan, .length = report.length};
    }
    return SearchEdge{.value = report.length,
                      .length = report.length,
                      .floor = report.state == EdgeState::kValid ? report.length : nan};
  };
  const ExactFn exact = [&](int e) { return graph.edge(e).report.state != EdgeState::kUnchecked; };
  const auto settle = [&](int e) {
    if (free[e]) {
      SetReport(graph, space, e, {1, 1});
    } else {
      graph.mutable_edge(e).report.state = EdgeState::kInvalid;
    }
  };
  const EvaluateFn evaluate = [&](const std::vector<int>& edges, const std::vector<double>&) {
    for (int e : edges) settle(e);
  };
  std::vector<double> to_go(graph.num_nodes());
  for (int v = 0; v < graph.num_nodes(); ++v) {
    to_go[v] = space.Distance(graph.node(v).q, graph.node(graph.goal()).q);
  }
  const auto measure = Measure::Make(MeasureSpec{.type = MeasureType::kLength});
  LazySearchStats stats;
  const SearchResult lazy =
      FindBestPathLazy(graph, *measure, see, exact, evaluate, &to_go, nullptr, 8, &stats);
  ASSERT_TRUE(lazy.found);
  EXPECT_GT(stats.evaluations, 100) << "few motions in collision: the test would not load it";
  for (int e = inputs; e < graph.num_edges(); ++e) settle(e);
  const EagerBest eager = EagerBestPath(graph, MeasureSpec{});
  ASSERT_TRUE(eager.found);
  EXPECT_EQ(lazy.edges, eager.edges);
}

TEST(SearchTest, InvalidEdgesAreNeverUsed) {
  const Space space = Plane();
  HGraph graph(space, {InputPath{.waypoints = {P(0, 0), P(5, 5), P(10, 10)}}}, 0);
  const int shortcut = graph.AddEdge(graph.start(), graph.goal(), false);
  for (int e = 0; e < graph.num_edges(); ++e) SetReport(graph, space, e, {1, 1});
  graph.mutable_edge(shortcut).report.state = EdgeState::kInvalid;
  // The two input edges are collinear with the shortcut, so only validity can tell them apart.
  const EagerBest r = EagerBestPath(graph, MeasureSpec{});
  ASSERT_TRUE(r.found);
  EXPECT_EQ(r.nodes.size(), 3u);
}

TEST(SearchTest, ProfiledEdgesWithoutACertificateAreNeverUsed) {
  const Space space = Plane();
  HGraph graph(space, {InputPath{.waypoints = {P(0, 0), P(5, 5), P(10, 10)}}}, 0);
  const int shortcut = graph.AddEdge(graph.start(), graph.goal(), false);
  for (int e = 0; e < graph.num_edges(); ++e) SetReport(graph, space, e, {1, 1});
  graph.mutable_edge(shortcut).report.certified = false;  // valid at its samples only
  for (const MeasureType type : {MeasureType::kLength, MeasureType::kBottleneckClearance}) {
    const EagerBest r = EagerBestPath(graph, MeasureSpec{.type = type});
    ASSERT_TRUE(r.found);
    EXPECT_EQ(r.nodes.size(), 3u);
  }
  graph.mutable_edge(graph.path_edges(0)[0]).report.certified = false;
  EXPECT_FALSE(EagerBestPath(graph, MeasureSpec{}).found);
}

TEST(SearchTest, SafeLengthTakesTheLongerSaferRoute) {
  const Space space = Plane();
  HGraph graph(space,
               {InputPath{.waypoints = {P(0, 0), P(5, 6), P(10, 10)}},
                InputPath{.waypoints = {P(0, 0), P(9, 1), P(10, 10)}}},
               0);
  SetReport(graph, space, graph.path_edges(0)[0], {0.5, 0.1, 0.5});  // short but tight
  SetReport(graph, space, graph.path_edges(0)[1], {0.5, 0.5});
  SetReport(graph, space, graph.path_edges(1)[0], {0.9, 0.8, 0.9});
  SetReport(graph, space, graph.path_edges(1)[1], {0.9, 0.9});
  const EagerBest shortest = EagerBestPath(graph, MeasureSpec{});
  const EagerBest safe =
      EagerBestPath(graph, MeasureSpec{.type = MeasureType::kSafeLength, .safety = 0.3});
  ASSERT_TRUE(shortest.found && safe.found);
  EXPECT_EQ(graph.node(shortest.nodes[1]).path, 0);
  EXPECT_EQ(graph.node(safe.nodes[1]).path, 1);
  EXPECT_FALSE(
      EagerBestPath(graph, MeasureSpec{.type = MeasureType::kSafeLength, .safety = 1.0}).found);
}

TEST(SearchTest, InverseClearanceIntegratesTheProfile) {
  const Space space = Plane();
  HGraph graph(space, {InputPath{.waypoints = {P(0, 0), P(3, 4)}}}, 0);
  SetReport(graph, space, 0, {1.0, 0.5, 1.0});
  const EagerBest r =
      EagerBestPath(graph, MeasureSpec{.type = MeasureType::kInverseClearance, .k = 1});
  ASSERT_TRUE(r.found);
  // Trapezoid over two halves of length 2.5: 2.5 * (1 + 2) / 2 * 2.
  EXPECT_NEAR(r.quality.inverse_clearance, 7.5, 1e-12);
  EXPECT_NEAR(r.quality.min_clearance, 0.5, 1e-12);
  EXPECT_NEAR(r.quality.avg_clearance, (2.5 * 0.75 * 2) / 5.0, 1e-12);
  EXPECT_NEAR(r.quality.length, 5.0, 1e-12);
}

}  // namespace
}  // namespace hgraph
