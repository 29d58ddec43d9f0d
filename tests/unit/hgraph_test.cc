#include "core/hgraph/hgraph.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "core/common/error.h"
#include "core/hgraph/bridge_candidates.h"

namespace hgraph {
namespace {

Space Plane() { return Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)); }
Config P(double x, double y) { return Eigen::Vector2d(x, y); }

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(HGraphTest, SharesStartAndGoalAndAddsInputEdges) {
  HGraph graph(Plane(),
               {InputPath{.name = "a", .waypoints = {P(0, 0), P(1, 1), P(2, 2), P(9, 9)}},
                InputPath{.name = "b", .waypoints = {P(0, 0), P(5, 1), P(9, 9)}}},
               1e-6);
  EXPECT_EQ(graph.num_nodes(), 2 + 2 + 1);
  EXPECT_EQ(graph.num_edges(), 3 + 2);
  EXPECT_EQ(graph.path_nodes(1).front(), graph.start());
  EXPECT_EQ(graph.path_nodes(1).back(), graph.goal());
  EXPECT_EQ(graph.node(graph.path_nodes(1)[1]).path, 1);
  EXPECT_EQ(graph.node(graph.path_nodes(1)[1]).index, 1);
  for (int e = 0; e < graph.num_edges(); ++e) {
    EXPECT_TRUE(graph.edge(e).input);
    EXPECT_EQ(graph.edge(e).report.state, EdgeState::kUnchecked);
  }
  // Adding an existing edge returns it.
  const int e = graph.AddEdge(graph.path_nodes(0)[1], graph.path_nodes(0)[0], false);
  EXPECT_EQ(e, graph.path_edges(0)[0]);
  EXPECT_EQ(graph.num_edges(), 5);
}

TEST(HGraphTest, SubdivisionPutsNodesOnTheInputEdges) {
  const Space space = Plane();
  const std::vector<InputPath> paths = {
      InputPath{.name = "a", .waypoints = {P(0, 0), P(0, 3.5), P(9, 9)}},
      InputPath{.name = "b", .waypoints = {P(0, 0), P(0.5, 0.5), P(9, 9)}}};
  const HGraph plain(space, paths, 1e-6);
  const HGraph dense(space, paths, 1e-6, /*max_node_spacing=*/1.0);
  // a: edge 0 (3.5) in 4 parts, edge 1 (|(9, 5.5)| = 10.55) in 11; b: edge 0 (0.71) whole,
  // edge 1 (12.02) in 13.
  EXPECT_EQ(dense.num_nodes(), plain.num_nodes() + 3 + 10 + 12);
  EXPECT_EQ(dense.num_edges(), (4 + 11) + (1 + 13));
  for (int p = 0; p < 2; ++p) {
    const std::vector<int>& ids = dense.path_nodes(p);
    double length = 0;
    double plain_length = 0;
    for (size_t j = 0; j + 1 < ids.size(); ++j) {
      const double d = space.Distance(dense.node(ids[j]).q, dense.node(ids[j + 1]).q);
      EXPECT_LE(d, 1.0 + 1e-12);
      length += d;
    }
    for (size_t j = 0; j + 1 < paths[p].waypoints.size(); ++j) {
      plain_length += space.Distance(paths[p].waypoints[j], paths[p].waypoints[j + 1]);
    }
    EXPECT_NEAR(length, plain_length, 1e-9) << "the input's motion is unchanged";
    for (size_t j = 1; j + 1 < ids.size(); ++j) {
      const HNode& node = dense.node(ids[j]);
      EXPECT_EQ(node.path, p);
      // The node is where the input is at fraction t of its edge (index, index + 1).
      const Config expected = space.Interpolate(paths[p].waypoints[node.index],
                                                paths[p].waypoints[node.index + 1], node.t);
      EXPECT_TRUE(node.q.isApprox(expected)) << "path " << p << " node " << j;
      EXPECT_TRUE(node.t == 0 || (node.t > 0 && node.t < 1));
    }
  }
  EXPECT_EQ(dense.node(dense.path_nodes(0)[4]).index, 1);  // a's waypoint 1, after 3 new nodes
  EXPECT_EQ(dense.node(dense.path_nodes(0)[4]).t, 0);
  // The automatic parameters keep the inputs' scale.
  EXPECT_DOUBLE_EQ(MeanInputEdgeLength(dense, space), MeanInputEdgeLength(plain, space));

  EXPECT_EQ(ErrorOf([&] { HGraph(space, paths, 1e-6, -1); }),
            "options.max_node_spacing: must be finite and >= 0 (0 = off)");
  EXPECT_EQ(ErrorOf([&] { HGraph(space, paths, 1e-6, NAN); }),
            "options.max_node_spacing: must be finite and >= 0 (0 = off)");
  EXPECT_NE(ErrorOf([&] { HGraph(space, paths, 1e-6, 1e-9); }).find("more than 10000 parts"),
            std::string::npos);
}

TEST(HGraphTest, RejectsBadInputNamingTheField) {
  const Space space = Plane();
  EXPECT_EQ(ErrorOf([&] { HGraph(space, {}, 1e-6); }),
            "paths: at least one input path is required");
  EXPECT_EQ(
      ErrorOf([&] { HGraph(space, {InputPath{.name = "solo", .waypoints = {P(0, 0)}}}, 1e-6); }),
      "paths[0].waypoints: path 'solo' has 1 waypoint(s); at least 2 are required");
  EXPECT_EQ(ErrorOf([&] {
              HGraph(space, {InputPath{.waypoints = {P(0, 0), Eigen::Vector3d(1, 1, 1)}}}, 1e-6);
            }),
            "paths[0].waypoints[1]: expected 2 coordinates, got 3");
  const std::string ends = ErrorOf([&] {
    HGraph(space,
           {InputPath{.name = "a", .waypoints = {P(0, 0), P(9, 9)}},
            InputPath{.name = "b", .waypoints = {P(0, 0), P(9, 8)}}},
           1e-6);
  });
  EXPECT_NE(ends.find("paths[1].waypoints[1]: path 'b' ends 1.0"), std::string::npos) << ends;
  EXPECT_NE(ErrorOf([&] {
              HGraph(space, {InputPath{.waypoints = {P(0, NAN), P(9, 9)}}}, 1e-6);
            }).find("paths[0].waypoints[0][1]: coordinate is not finite"),
            std::string::npos);
}

std::vector<InputPath> RandomPaths(std::mt19937_64& rng, int count, int nodes) {
  std::uniform_real_distribution<double> coord(0.5, 9.5);
  std::vector<InputPath> paths;
  for (int p = 0; p < count; ++p) {
    InputPath path;
    path.waypoints.push_back(P(0, 0));
    for (int k = 0; k < nodes; ++k) path.waypoints.push_back(P(coord(rng), coord(rng)));
    path.waypoints.push_back(P(10, 10));
    paths.push_back(path);
  }
  return paths;
}

TEST(BridgeCandidatesTest, AllPairsCoversEveryNonEdgePair) {
  std::mt19937_64 rng(3);
  const Space space = Plane();
  HGraph graph(space, RandomPaths(rng, 3, 6), 1e-9);
  const CandidateSet set =
      BridgeCandidates(graph, space, CandidateOptions{.variant = Variant::kAllPairs});
  const int n = graph.num_nodes();
  EXPECT_EQ(static_cast<int>(set.pairs.size()), n * (n - 1) / 2 - graph.num_edges());
}

TEST(BridgeCandidatesTest, EveryVariantStopsAtAStoppedTokenAndGoesOnWithALiveOne) {
  std::mt19937_64 rng(5);
  const Space space = Plane();
  HGraph graph(space, RandomPaths(rng, 3, 6), 1e-9);
  for (Variant variant : {Variant::kAllPairs, Variant::kNeighborhood, Variant::kKNearest,
                          Variant::kEditDistance, Variant::kEditDistanceNeighborhood}) {
    const CandidateOptions options{.variant = variant, .radius = 2.5};
    CancelToken live;
    const CandidateSet set = BridgeCandidates(graph, space, options, {}, &live);
    EXPECT_EQ(set.pairs, BridgeCandidates(graph, space, options).pairs) << VariantName(variant);
    std::set<std::pair<int, int>> unique(set.pairs.begin(), set.pairs.end());
    EXPECT_EQ(unique.size(), set.pairs.size()) << VariantName(variant);
    CancelToken stopped;
    stopped.Cancel();
    try {
      BridgeCandidates(graph, space, options, {}, &stopped);
      ADD_FAILURE() << VariantName(variant) << ": a stopped token did not stop it";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kCancelled) << VariantName(variant);
    }
  }
}

TEST(BridgeCandidatesTest, NeighborhoodRespectsRadiusAndKnnCountsNeighbours) {
  std::mt19937_64 rng(4);
  const Space space = Plane();
  HGraph graph(space, RandomPaths(rng, 3, 8), 1e-9);
  const CandidateSet near = BridgeCandidates(
      graph, space, CandidateOptions{.variant = Variant::kNeighborhood, .radius = 2.5});
  for (const auto& [u, v] : near.pairs) {
    EXPECT_LE(space.Distance(graph.node(u).q, graph.node(v).q), 2.5);
  }
  int close = 0;
  for (int u = 0; u < graph.num_nodes(); ++u) {
    for (int v = u + 1; v < graph.num_nodes(); ++v) {
      close += space.Distance(graph.node(u).q, graph.node(v).q) <= 2.5 && graph.FindEdge(u, v) < 0;
    }
  }
  EXPECT_EQ(static_cast<int>(near.pairs.size()), close);
  const CandidateSet knn =
      BridgeCandidates(graph, space, CandidateOptions{.variant = Variant::kKNearest, .phi = 2});
  // Exactly the union over nodes u of u's two nearest other nodes (random real coordinates: no
  // ties), as unordered pairs, less the pairs an input edge already joins.
  std::set<std::pair<int, int>> expected;
  for (int u = 0; u < graph.num_nodes(); ++u) {
    std::vector<std::pair<double, int>> by_distance;
    for (int v = 0; v < graph.num_nodes(); ++v) {
      if (v != u) by_distance.emplace_back(space.Distance(graph.node(u).q, graph.node(v).q), v);
    }
    std::sort(by_distance.begin(), by_distance.end());
    for (int k = 0; k < 2; ++k) {
      const int v = by_distance[k].second;
      if (graph.FindEdge(u, v) < 0) expected.insert({std::min(u, v), std::max(u, v)});
    }
  }
  const std::set<std::pair<int, int>> found(knn.pairs.begin(), knn.pairs.end());
  EXPECT_EQ(found.size(), knn.pairs.size()) << "no pair twice";
  EXPECT_EQ(found, expected);
  EXPECT_FALSE(expected.empty());
}

TEST(BridgeCandidatesTest, EditDistanceIsLinearPerPairOfPaths) {
  std::mt19937_64 rng(5);
  const Space space = Plane();
  for (int nodes : {10, 40, 160}) {
    HGraph graph(space, RandomPaths(rng, 4, nodes), 1e-9);
    const CandidateSet set =
        BridgeCandidates(graph, space, CandidateOptions{.variant = Variant::kEditDistance});
    EXPECT_EQ(set.alignments, 6);
    // At most two bridges per node of each path in each pair: 2 (n_a + n_b) per pair.
    EXPECT_LE(static_cast<int>(set.pairs.size()), 6 * 2 * 2 * (nodes + 2));
    EXPECT_GT(static_cast<int>(set.pairs.size()), nodes);
  }
}

TEST(BridgeCandidatesTest, EditDistanceBridgesAGapToItsBoundaries) {
  const Space space = Plane();
  // b leaves a at node 2 on a detour and rejoins at node 3.
  HGraph graph(space,
               {InputPath{.waypoints = {P(0, 0), P(1, 1), P(2, 2), P(3, 3), P(10, 10)}},
                InputPath{.waypoints = {P(0, 0), P(1, 1.1), P(2, 2.1), P(2, 9), P(4, 9), P(3, 3.1),
                                        P(10, 10)}}},
               1e-9);
  const CandidateSet set = BridgeCandidates(
      graph, space,
      CandidateOptions{.variant = Variant::kEditDistance, .gap_init = 1.0, .gap_extend = 0.5});
  const auto has = [&](int pa, int ia, int pb, int ib) {
    const int u = graph.path_nodes(pa)[ia], v = graph.path_nodes(pb)[ib];
    for (const auto& [x, y] : set.pairs) {
      if ((x == u && y == v) || (x == v && y == u)) return true;
    }
    return false;
  };
  EXPECT_TRUE(has(0, 1, 1, 1));  // matched pairs
  EXPECT_TRUE(has(0, 2, 1, 2));
  EXPECT_TRUE(has(1, 3, 0, 2));  // detour nodes to both boundaries
  EXPECT_TRUE(has(1, 3, 0, 3));
  EXPECT_TRUE(has(1, 4, 0, 2));
  EXPECT_TRUE(has(1, 4, 0, 3));
  EXPECT_FALSE(has(1, 3, 0, 1));  // not to the rest of the path
}

TEST(BridgeCandidatesTest, UnknownVariantIsNamed) {
  EXPECT_EQ(ErrorOf([] { ParseVariant("bogus", "variant"); }),
            "variant: unknown variant 'bogus' (expected all-pairs, neighborhood, knn, "
            "edit-distance or edit-distance-neighborhood)");
  EXPECT_EQ(ParseVariant("knn", "variant"), Variant::kKNearest);
}

}  // namespace
}  // namespace hgraph
