// How few edges any lazy search could check on one length merge (no post-optimization), beside
// what eager and lazy evaluation check. An oracle knows every edge's verdict (from an eager
// merge) and plays LazySP with a perfect edge selector: it takes the shortest start-goal path
// under the bounds (the metric length, as the lazy search does), and while that path holds an
// invalid edge it checks invalid edges of it only (one per round, or all of them), never a
// valid one, then checks the final path's own edges. What it checks is what a lazy search that
// proves the same optimum must at least pay for the invalid edges it cannot avoid, up to the
// choice of which invalid edge of a path to check.
//
// It also prints a bound that holds for every algorithm, not only LazySP: an invalid edge (u, v)
// with d(s, u) + |uv| + d(v, g) < optimum, where d is the shortest distance over valid edges,
// lies on a start-goal path whose other edges are all valid and that is shorter than the optimum
// under the bounds. Any search that knows an unchecked edge only by its bound must check (u, v)
// before it can prove the optimum, and it must check the returned path's own edges. Not a test:
// it prints.
//
//   build/tests/bench/lazy_limit --scene scenes/grid/scene.json --paths P.json [--inputs 3]
//       [--variant all-pairs]
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <queue>
#include <string>
#include <vector>

#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "core/search/search.h"
#include "tests/unit/search_oracle.h"

namespace hgraph {
namespace {

// Edges the oracle checks: the invalid ones it reveals plus the final path's.
struct OracleCount {
  int64_t invalid = 0;
  int64_t path = 0;
  int64_t rounds = 0;
  double length = 0;
};

OracleCount Oracle(const HGraph& graph, bool reveal_all) {
  const auto measure = Measure::Make({.type = MeasureType::kLength});
  std::vector<char> revealed(graph.num_edges(), 0);
  const auto see = [&](int e) {
    const EdgeReport& report = graph.edge(e).report;
    const double length = report.length;
    if (revealed[e])
      return SearchEdge{.value = std::numeric_limits<double>::quiet_NaN(), .length = length};
    return SearchEdge{.value = length, .length = length};
  };
  OracleCount count;
  for (;;) {
    ++count.rounds;
    const SearchResult path = testing::EagerBestPath(graph, *measure, see);
    HGRAPH_CHECK(path.found);
    bool clean = true;
    for (int e : path.edges) {
      const EdgeReport& report = graph.edge(e).report;
      if (report.state == EdgeState::kValid && report.usable()) continue;
      clean = false;
      revealed[e] = 1;
      ++count.invalid;
      if (!reveal_all) break;
    }
    if (clean) {
      count.path = static_cast<int64_t>(path.edges.size());
      count.length = path.value;
      return count;
    }
  }
}

// Shortest distances from `source` over the usable valid edges of the checked H-Graph.
std::vector<double> ValidDistances(const HGraph& graph, int source) {
  std::vector<double> dist(graph.num_nodes(), std::numeric_limits<double>::infinity());
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  dist[source] = 0;
  open.push({0, source});
  while (!open.empty()) {
    const auto [d, u] = open.top();
    open.pop();
    if (d > dist[u]) continue;
    for (const auto& [v, e] : graph.neighbours(u)) {
      const EdgeReport& report = graph.edge(e).report;
      if (report.state != EdgeState::kValid || !report.usable()) continue;
      if (d + report.length < dist[v]) {
        dist[v] = d + report.length;
        open.push({dist[v], v});
      }
    }
  }
  return dist;
}

// The invalid edges every search must check to prove `optimum` (see the top of this file).
int64_t ForcedInvalidEdges(const HGraph& graph, double optimum) {
  const std::vector<double> from_start = ValidDistances(graph, graph.start());
  const std::vector<double> to_goal = ValidDistances(graph, graph.goal());
  const double below = optimum * (1 - 1e-9);
  int64_t forced = 0;
  for (int e = 0; e < graph.num_edges(); ++e) {
    const HEdge& edge = graph.edge(e);
    if (edge.report.state == EdgeState::kValid && edge.report.usable()) continue;
    const double through = edge.report.length + std::min(from_start[edge.u] + to_goal[edge.v],
                                                         from_start[edge.v] + to_goal[edge.u]);
    if (through < below) ++forced;
  }
  return forced;
}

int Main(int argc, char** argv) {
  CLI::App app{"the fewest edges a lazy length merge could check, beside eager and lazy"};
  std::string scene_file;
  std::string paths_file;
  std::string variant = "all-pairs";
  int inputs = 0;
  app.add_option("--scene", scene_file, "Scene JSON")->required();
  app.add_option("--paths", paths_file, "Input paths (PathSet JSON)")->required();
  app.add_option("--inputs", inputs, "Use the first N paths (0 = all)");
  app.add_option("--variant", variant, "H-Graph variant");
  CLI11_PARSE(app, argc, argv);

  const v1::Scene proto = ReadSceneFile(scene_file);
  const auto scene =
      SceneFromProto(proto, std::filesystem::path(scene_file).parent_path().string(), {});
  const auto world = std::make_shared<const CollisionWorld>(scene);
  const LocalPlanner planner(world, {.resolution = SceneResolution(proto)});
  std::vector<InputPath> paths = LoadPathsFile(paths_file, scene->space);
  if (inputs > 0 && static_cast<int>(paths.size()) > inputs) paths.resize(inputs);

  MergeRequest request{.paths = paths, .measure = {.type = MeasureType::kLength}};
  request.options.candidates.variant = ParseVariant(variant, "variant");
  request.options.optimize_ms = 0;
  request.options.evaluation = Evaluation::kLazy;
  const MergeResult lazy = Merge(planner, request);
  request.options.evaluation = Evaluation::kEager;
  HybridizationSession eager_session(planner, request);
  const MergeResult eager = eager_session.Query(request.measure);
  const HGraph& graph = eager_session.graph();
  int64_t valid = 0;
  for (int e = 0; e < graph.num_edges(); ++e) {
    if (graph.edge(e).report.state == EdgeState::kValid) ++valid;
  }
  std::printf("%zu inputs, %s: %d nodes, %d edges (%lld valid)\n", paths.size(), variant.c_str(),
              graph.num_nodes(), graph.num_edges(), static_cast<long long>(valid));
  std::printf("eager: %lld edges checked, length %.6g\n",
              static_cast<long long>(eager.stats.edges_checked), eager.hgraph_objective);
  std::printf("lazy:  %lld edges checked, length %.6g\n",
              static_cast<long long>(lazy.stats.edges_checked), lazy.hgraph_objective);
  for (bool reveal_all : {false, true}) {
    const OracleCount oracle = Oracle(graph, reveal_all);
    std::printf(
        "oracle (%s invalid edge of the path per round): %lld edges (%lld invalid + %lld on the "
        "path), %lld rounds, length %.6g; %.1f%% of eager's\n",
        reveal_all ? "every" : "one", static_cast<long long>(oracle.invalid + oracle.path),
        static_cast<long long>(oracle.invalid), static_cast<long long>(oracle.path),
        static_cast<long long>(oracle.rounds), oracle.length,
        100.0 * static_cast<double>(oracle.invalid + oracle.path) /
            static_cast<double>(eager.stats.edges_checked));
  }
  const int64_t forced = ForcedInvalidEdges(graph, eager.hgraph_objective);
  const OracleCount final_path = Oracle(graph, true);
  std::printf(
      "any search: at least %lld edges (%lld invalid edges on a path shorter than the optimum "
      "whose other edges are valid + %lld on the path); %.1f%% of eager's\n",
      static_cast<long long>(forced + final_path.path), static_cast<long long>(forced),
      static_cast<long long>(final_path.path),
      100.0 * static_cast<double>(forced + final_path.path) /
          static_cast<double>(eager.stats.edges_checked));
  return 0;
}

}  // namespace
}  // namespace hgraph

int main(int argc, char** argv) {
  try {
    return hgraph::Main(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
