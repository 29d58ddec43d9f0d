// Costs of the engine's parts on the OMPL circles scene and on a mesh scene: one collision check,
// one distance query, one edge check, and a whole merge per variant.
#include <benchmark/benchmark.h>

#include <random>
#include <utility>
#include <vector>

#include "core/collision/collision_world.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "tests/unit/test_scenes.h"

namespace hgraph {
namespace {

std::shared_ptr<const CollisionWorld> Circles() {
  static const auto world = std::make_shared<const CollisionWorld>(testing::CirclesScene());
  return world;
}

// A rod (box mesh made of 12 triangles) in SE(3) among a 5 x 5 x 5 lattice of mesh boxes.
std::shared_ptr<const CollisionWorld> Lattice() {
  static const auto world = [] {
    auto box = std::make_shared<Mesh>();
    for (int i = 0; i < 8; ++i) {
      box->vertices.emplace_back(i & 1 ? 0.5 : -0.5, i & 2 ? 0.5 : -0.5, i & 4 ? 0.5 : -0.5);
    }
    const int faces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                              {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    for (const auto& f : faces) box->triangles.emplace_back(f[0], f[1], f[2]);
    auto scene = std::make_shared<Scene>(Scene{
        .name = "lattice",
        .space = Space::SE3(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(10, 10, 10)),
    });
    for (int x = 0; x < 5; ++x) {
      for (int y = 0; y < 5; ++y) {
        for (int z = 0; z < 5; ++z) {
          Obstacle o{.name = "b", .shape = Shape{.type = ShapeType::kMesh, .mesh = box}};
          o.pose.translation() = Eigen::Vector3d(1 + 2 * x, 1 + 2 * y, 1 + 2 * z);
          scene->obstacles.push_back(o);
        }
      }
    }
    RobotBody rod{.name = "rod", .shape = Shape{.type = ShapeType::kMesh, .mesh = box}};
    rod.offset.linear() = Eigen::Vector3d(1.5, 0.2, 0.2).asDiagonal();
    scene->robot.push_back(rod);
    return std::make_shared<const CollisionWorld>(scene);
  }();
  return world;
}

std::vector<Config> Samples(const Space& space, int count) {
  std::mt19937_64 rng(42);
  std::vector<Config> out;
  for (int i = 0; i < count; ++i) out.push_back(space.Sample(rng));
  return out;
}

void BM_CollisionCheck(benchmark::State& state, std::shared_ptr<const CollisionWorld> world) {
  auto context = world->MakeContext();
  const std::vector<Config> qs = Samples(world->space(), 1024);
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(context->Valid(qs[i++ % qs.size()]));
}

void BM_DistanceQuery(benchmark::State& state, std::shared_ptr<const CollisionWorld> world) {
  auto context = world->MakeContext();
  const std::vector<Config> qs = Samples(world->space(), 1024);
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(context->Clearance(qs[i++ % qs.size()]));
}

BENCHMARK_CAPTURE(BM_CollisionCheck, circles, Circles());
BENCHMARK_CAPTURE(BM_DistanceQuery, circles, Circles());
BENCHMARK_CAPTURE(BM_CollisionCheck, lattice_mesh, Lattice());
BENCHMARK_CAPTURE(BM_DistanceQuery, lattice_mesh, Lattice());

// Free straight motions of the rod in the lattice (valid under the clearance check), each ~2
// units long, for the edge-check modes below.
const std::vector<std::pair<Config, Config>>& LatticeEdges() {
  static const auto edges = [] {
    const LocalPlanner planner(Lattice(), {.resolution = 0.004});
    const Space& space = planner.space();
    std::mt19937_64 rng(7);
    std::vector<std::pair<Config, Config>> out;
    while (out.size() < 64) {
      const Config from = space.Sample(rng);
      Config to = space.Sample(rng);
      to.head<3>() = from.head<3>() + 2.0 * (to.head<3>() - from.head<3>()).normalized();
      if (!space.InBounds(to)) continue;
      if (planner.CheckEdge({.from = &from, .to = &to, .proof = EdgeProof::kProfile}).state ==
          EdgeState::kValid) {
        out.emplace_back(from, to);
      }
    }
    return out;
  }();
  return edges;
}

// One edge check of a free motion: 0 = sampled collision test, 1 = certify (conservative
// advancement), 2 = clearance profile (the merge's check for clearance measures).
void BM_EdgeCheck(benchmark::State& state) {
  const LocalPlanner planner(Lattice(), {.resolution = 0.004});
  const auto& edges = LatticeEdges();
  const int mode = static_cast<int>(state.range(0));
  size_t i = 0;
  int64_t queries = 0, checks = 0, edges_run = 0;
  for (auto _ : state) {
    const auto& [from, to] = edges[i++ % edges.size()];
    const EdgeReport report = planner.CheckEdge({.from = &from,
                                                 .to = &to,
                                                 .proof = mode == 2   ? EdgeProof::kProfile
                                                          : mode == 1 ? EdgeProof::kCertificate
                                                                      : EdgeProof::kSamples});
    benchmark::DoNotOptimize(report.state);
    queries += report.distance_queries;
    checks += report.collision_checks;
    ++edges_run;
  }
  state.SetLabel(mode == 0 ? "sampled" : mode == 1 ? "certify" : "profile");
  state.counters["distances_per_edge"] = static_cast<double>(queries) / edges_run;
  state.counters["checks_per_edge"] = static_cast<double>(checks) / edges_run;
}
BENCHMARK(BM_EdgeCheck)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

void BM_MergeCircles(benchmark::State& state) {
  const LocalPlanner planner(Circles());
  const auto variant = static_cast<Variant>(state.range(0));
  const auto measure = static_cast<MeasureType>(state.range(1));
  MergeResult last;
  for (auto _ : state) {
    last =
        Merge(planner, MergeRequest{.paths = testing::CirclePaths(),
                                    .measure = {.type = measure},
                                    .options = {.candidates = {.variant = variant}, .threads = 1}});
  }
  state.SetLabel(std::string(VariantName(variant)) + "/" + MeasureTypeName(measure));
  state.counters["candidates"] = static_cast<double>(last.stats.candidate_edges);
  state.counters["checks"] = static_cast<double>(last.stats.collision_checks);
  state.counters["distances"] = static_cast<double>(last.stats.distance_queries);
  state.counters["length"] = last.quality.length;
}
BENCHMARK(BM_MergeCircles)
    ->ArgsProduct({{static_cast<int>(Variant::kAllPairs), static_cast<int>(Variant::kNeighborhood),
                    static_cast<int>(Variant::kKNearest), static_cast<int>(Variant::kEditDistance),
                    static_cast<int>(Variant::kEditDistanceNeighborhood)},
                   {static_cast<int>(MeasureType::kLength),
                    static_cast<int>(MeasureType::kInverseClearance)}})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace hgraph

BENCHMARK_MAIN();
