// core/distance's lower bound on clearance, on the mesh scenes with real FCL: it never exceeds
// the exact clearance, its grid holds FCL's point distances, its spheres cover the robot, and
// certificates taken with it are certificates with exact clearances.
#include "core/distance/clearance_bound.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/merge/merge.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"

namespace hgraph {
namespace {

const std::string kRoot = HGRAPH_SOURCE_DIR;

struct MeshProblem {
  std::string name;
  std::string file;
};

// The bench's SE(3) problems, the built-in wrenches (one, and two with self-collision), and
// the OMPL.app problems (SE(2) and SE(3)).
std::vector<MeshProblem> MeshProblems() {
  return {{"hole_wall", kRoot + "/tests/bench/scenes/hole_wall/scene.json"},
          {"two_slots", kRoot + "/tests/bench/scenes/two_slots/scene.json"},
          {"wrench", kRoot + "/scenes/wrench/scene.json"},
          {"double_wrench", kRoot + "/scenes/double_wrench/scene.json"},
          {"wall_planar", kRoot + "/tests/data/ompl_app/wall_planar.cfg"},
          {"car_planar", kRoot + "/tests/data/ompl_app_car/car_planar.cfg"},
          {"car_3d", kRoot + "/tests/data/ompl_app_car/car_3d.cfg"}};
}

std::shared_ptr<const CollisionWorld> LoadWorld(const MeshProblem& p) {
  return std::make_shared<const CollisionWorld>(LoadSceneFile(p.file));
}

// Fields of a quarter of the default's points: the property is the same, the tests faster.
constexpr ClearanceBoundOptions kTestOptions{.target_cells = 250'000};

TEST(ClearanceBoundTest, NeverExceedsTheExactClearance) {
  int64_t states = 0;
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    const auto bound = ClearanceBound::Build(world, kTestOptions);
    ASSERT_NE(bound, nullptr) << "every mesh problem gets a field";
    auto context = world->MakeContext();
    std::mt19937_64 rng(26);
    int free = 0;
    int decided = 0;  // free states whose bound is positive, so that a certificate can use it
    double tightness = 0;
    for (int i = 0; i < 1500; ++i) {
      const Config q = world->space().Sample(rng);
      const double exact = context->Clearance(q);
      const double lower = bound->LowerBound(q);
      ASSERT_LE(lower, exact) << "state " << i;
      if (exact > 0) {
        ++free;
        if (lower > 0) {
          ++decided;
          tightness += lower / exact;
        }
      }
      ++states;
    }
    // A bound that is never positive would be true and useless.
    ASSERT_GT(free, 0);
    EXPECT_GT(decided, free / 4) << decided << " of " << free << " free states";
    std::printf("%s: bound positive at %d of %d free states, mean bound / exact %.2f, cell %.4g\n",
                p.name.c_str(), decided, free, decided > 0 ? tightness / decided : 0.0,
                bound->field().cell_size());
  }
  EXPECT_GE(states, 10'000);
}

// Every grid point holds FCL's distance from it to the obstacles, rounded down to a float, and
// no more than the distance to any obstacle vertex (a check that does not go through FCL).
TEST(ClearanceBoundTest, GridPointsHoldTheirDistance) {
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    const auto bound = ClearanceBound::Build(world, kTestOptions);
    ASSERT_NE(bound, nullptr);
    const DistanceField& field = bound->field();
    auto context = world->MakeContext();
    std::vector<Eigen::Vector3d> vertices;
    for (const Obstacle& o : world->scene().obstacles) {
      if (o.shape.type != ShapeType::kMesh) continue;
      for (const Eigen::Vector3d& v : o.shape.mesh->vertices) vertices.push_back(o.pose * v);
    }
    std::mt19937_64 rng(7);
    const Eigen::Vector3i n = field.counts();
    for (int s = 0; s < 300; ++s) {
      const int64_t i = std::uniform_int_distribution<int64_t>(0, n[0] - 1)(rng);
      const int64_t j = std::uniform_int_distribution<int64_t>(0, n[1] - 1)(rng);
      const int64_t k = std::uniform_int_distribution<int64_t>(0, n[2] - 1)(rng);
      const Eigen::Vector3d g = field.Point(i, j, k);
      const double stored = field.Value(i, j, k);
      const double fcl = std::max(0.0, context->ObstacleDistance(g));
      ASSERT_LE(stored, fcl);
      ASSERT_GE(stored, fcl * (1 - 1e-6) - 1e-9);
      for (const Eigen::Vector3d& v : vertices) ASSERT_LE(stored, (g - v).norm() + 1e-9);
      // The bound at a grid point is its own value; half a cell away, it loses that distance.
      EXPECT_DOUBLE_EQ(field.LowerBound(g), stored);
      const Eigen::Vector3d off = g + Eigen::Vector3d(0.4, 0, 0) * field.cell_size();
      if (i + 1 < n[0]) {
        EXPECT_NEAR(field.LowerBound(off), stored - 0.4 * field.cell_size(), 1e-9);
      }
    }
  }
}

// Every vertex and sampled surface point of every robot triangle lies in a sphere of the
// body's cover, and the spheres are no larger than asked.
TEST(ClearanceBoundTest, SpheresCoverEveryRobotTriangle) {
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto scene = LoadSceneFile(p.file);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> unit(0, 1);
    for (const RobotBody& body : scene->robot) {
      ASSERT_EQ(body.shape.type, ShapeType::kMesh);
      const Mesh& mesh = *body.shape.mesh;
      for (const double max_radius : {0.5, 0.05}) {
        // Enough pieces that no triangle stops short of the radius.
        const SphereCover cover = CoverShape(body.shape, max_radius, 1 << 16);
        ASSERT_FALSE(cover.spheres.empty());
        for (const CoverSphere& s : cover.spheres) {
          ASSERT_LE(s.radius, max_radius * (1 + 1e-9) + 1e-9);
        }
        const auto covered = [&](const Eigen::Vector3d& x) {
          return std::any_of(cover.spheres.begin(), cover.spheres.end(), [&](const CoverSphere& s) {
            return (x - s.centre).norm() <= s.radius;
          });
        };
        for (const Eigen::Vector3i& t : mesh.triangles) {
          for (int c = 0; c < 3; ++c) ASSERT_TRUE(covered(mesh.vertices[t[c]]));
          for (int s = 0; s < 8; ++s) {
            double u = unit(rng), v = unit(rng);
            if (u + v > 1) u = 1 - u, v = 1 - v;
            const Eigen::Vector3d x = mesh.vertices[t[0]] +
                                      u * (mesh.vertices[t[1]] - mesh.vertices[t[0]]) +
                                      v * (mesh.vertices[t[2]] - mesh.vertices[t[0]]);
            ASSERT_TRUE(covered(x));
          }
        }
        // The tree's nodes hold their spheres: the root holds every one.
        const CoverSphere& root = cover.nodes.at(0).sphere;
        for (const CoverSphere& s : cover.spheres) {
          ASSERT_LE((s.centre - root.centre).norm() + s.radius, root.radius);
        }
      }
    }
  }
}

TEST(ClearanceBoundTest, OptionsAreChecked) {
  const auto world = LoadWorld(MeshProblems()[0]);
  try {
    ClearanceBound::Build(world, {.cell_size = -1});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "cell_size");
  }
  try {
    ClearanceBound::Build(world, {.cell_size = 1e-4});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "max_cells");
  }
  try {
    CoverShape(world->scene().robot[0].shape, 0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "max_radius");
  }
  // Coarser than a quarter of the robot's radius: no field, exact distances only.
  EXPECT_EQ(ClearanceBound::Build(world, {.cell_size = world->BodyRadius(0)}), nullptr);
}

// Random motions between free states, certified with and without the bound: a collision is
// found only where there is one, every motion certified with the bound is certified with exact
// clearances too, and the bound saves exact distance queries.
TEST(ClearanceBoundTest, CertificatesWithTheBoundAreExactCertificates) {
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    const auto bound = ClearanceBound::Build(world, kTestOptions);
    ASSERT_NE(bound, nullptr);
    const LocalPlanner exact(world, {.direction_bound = false});
    const LocalPlanner bounded(world, {.clearance_bound = bound, .direction_bound = false});
    std::mt19937_64 rng(11);
    std::vector<Config> free;
    while (free.size() < 60) {
      const Config q = world->space().Sample(rng);
      if (exact.Clearance(q) > 0) free.push_back(q);
    }
    int certified = 0;
    for (size_t i = 0; i + 1 < free.size(); ++i) {
      // Short motions (a tenth of the way to the next state) are mostly free; long ones mostly
      // collide.
      const Config to = world->space().Interpolate(free[i], free[i + 1], i % 2 ? 0.1 : 1.0);
      for (const EdgeProof mode : {EdgeProof::kCertificate, EdgeProof::kCertificateOrGiveUp}) {
        const EdgeCheckRequest request{.from = &free[i], .to = &to, .proof = mode};
        const EdgeReport with = bounded.CheckEdge(request);
        const EdgeReport without = exact.CheckEdge(request);
        const EdgeReport profile =
            exact.CheckEdge({.from = &free[i], .to = &to, .proof = EdgeProof::kProfile});
        if (with.state == EdgeState::kInvalid) {
          EXPECT_EQ(profile.state, EdgeState::kInvalid) << "motion " << i;
        }
        if (with.certified) {
          ++certified;
          EXPECT_EQ(with.state, EdgeState::kValid);
          EXPECT_TRUE(profile.certified) << "motion " << i;
          if (mode == EdgeProof::kCertificate) {
            EXPECT_TRUE(without.certified) << "motion " << i;
          }
        }
        if (mode == EdgeProof::kCertificate) {
          EXPECT_EQ(with.certified, without.certified) << "motion " << i;
        }
      }
    }
    EXPECT_GT(certified, 10);
    EXPECT_GT(bounded.total_bound_queries(), 0);
    EXPECT_LT(bounded.total_distance_queries(), exact.total_distance_queries() / 2);
    std::printf("%s: %d certified; exact distance queries %lld with the bound, %lld without\n",
                p.name.c_str(), certified, static_cast<long long>(bounded.total_distance_queries()),
                static_cast<long long>(exact.total_distance_queries()));
  }
}

// A default merge on the bench's fixed hole_wall inputs, checked with the bound: its path passes
// CheckPaths on an exact checker, certified.
TEST(ClearanceBoundTest, MergedPathsWithTheBoundAreCertifiedExactly) {
  const MeshProblem p = MeshProblems()[0];
  const auto world = LoadWorld(p);
  const auto bound = ClearanceBound::Build(world);
  ASSERT_NE(bound, nullptr);
  const LocalPlanner exact(world, {.direction_bound = false});
  const LocalPlanner bounded(world, {.clearance_bound = bound, .direction_bound = false});
  const std::vector<InputPath> inputs =
      LoadPathsFile(kRoot + "/tests/bench/results/seed1/inputs/hole_wall.json", world->space());
  const MergeResult merged = Merge(bounded, MergeRequest{.paths = inputs});
  EXPECT_GT(bounded.total_bound_queries(), 0);
  const PathCheckResult check = CheckPaths(exact, PathCheckRequest{.paths = {merged.path}});
  ASSERT_EQ(check.paths.size(), 1u);
  EXPECT_TRUE(check.paths[0].valid) << check.paths[0].invalid_reason;
  EXPECT_TRUE(check.paths[0].certified);
}

}  // namespace
}  // namespace hgraph
