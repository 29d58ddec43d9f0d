#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "tests/unit/mesh_problems.h"

namespace hgraph {
namespace {

constexpr double kTolerance = 1e-6;

using testing::BoxMesh;

// A UV sphere: `rings` latitude bands of `segments` quads, poles fanned.
std::shared_ptr<const Mesh> SphereMesh(double radius, int rings, int segments) {
  auto mesh = std::make_shared<Mesh>();
  mesh->vertices.emplace_back(0, 0, radius);
  for (int r = 1; r < rings; ++r) {
    const double phi = std::numbers::pi * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double theta = 2 * std::numbers::pi * s / segments;
      mesh->vertices.emplace_back(radius * std::sin(phi) * std::cos(theta),
                                  radius * std::sin(phi) * std::sin(theta), radius * std::cos(phi));
    }
  }
  mesh->vertices.emplace_back(0, 0, -radius);
  const int south = static_cast<int>(mesh->vertices.size()) - 1;
  auto at = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) {
    mesh->triangles.emplace_back(0, at(1, s), at(1, s + 1));
    mesh->triangles.emplace_back(south, at(rings - 1, s + 1), at(rings - 1, s));
    for (int r = 1; r + 1 < rings; ++r) {
      mesh->triangles.emplace_back(at(r, s), at(r + 1, s), at(r + 1, s + 1));
      mesh->triangles.emplace_back(at(r, s), at(r + 1, s + 1), at(r, s + 1));
    }
  }
  return mesh;
}

Shape BoxShape(const Eigen::Vector3d& size) {
  return Shape{.type = ShapeType::kBox, .box_size = size};
}
Shape MeshShape(std::shared_ptr<const Mesh> mesh) {
  return Shape{.type = ShapeType::kMesh, .mesh = std::move(mesh), .source = "test"};
}

Config Vec(std::initializer_list<double> values) {
  Config q(static_cast<int>(values.size()));
  int i = 0;
  for (double v : values) q[i++] = v;
  return q;
}

struct Disc {
  double x, y, r;
};

std::vector<Disc> LoadDiscs() {
  const std::string file = std::string(HGRAPH_TEST_DATA_DIR) + "/ompl-2d/circle_obstacles.txt";
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot open test data file " + file);
  std::string line;
  std::getline(in, line);
  std::getline(in, line);
  std::vector<Disc> discs;
  int id;
  Disc d;
  while (in >> id >> d.x >> d.y >> d.r) discs.push_back(d);
  return discs;
}

// The discs as cylinders along Z, and a round robot (radius 0: a point) moving in R^2.
std::shared_ptr<const Scene> CircleScene(const std::vector<Disc>& discs, double robot_radius) {
  auto scene = std::make_shared<Scene>(Scene{
      .name = "circles",
      .space = Space::RealVector(Eigen::Vector2d(0, -5), Eigen::Vector2d(70, 70)),
  });
  for (const Disc& d : discs) {
    Obstacle o{.shape = Shape{.type = ShapeType::kCylinder, .radius = d.r, .length = 2}};
    o.pose.translation() = Eigen::Vector3d(d.x, d.y, 0);
    scene->obstacles.push_back(o);
  }
  scene->robot.push_back(RobotBody{
      .name = "disc", .shape = Shape{.type = ShapeType::kSphere, .radius = robot_radius}});
  return scene;
}

double AnalyticDiscClearance(const std::vector<Disc>& discs, double robot_radius, const Config& q) {
  double best = std::numeric_limits<double>::infinity();
  for (const Disc& d : discs) best = std::min(best, std::hypot(q[0] - d.x, q[1] - d.y) - d.r);
  return std::max(0.0, best - robot_radius);
}

// An SE(3) mesh robot (a sphere of 960 triangles) among 40 mesh spheres and boxes.
std::shared_ptr<const Scene> MeshScene() {
  auto scene = std::make_shared<Scene>(Scene{
      .name = "meshes",
      .space = Space::SE3(Eigen::Vector3d::Constant(-10), Eigen::Vector3d::Constant(10)),
  });
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> coord(-9, 9);
  const auto ball = SphereMesh(1.5, 16, 32);
  const auto box = BoxMesh(Eigen::Vector3d(2, 3, 1));
  for (int i = 0; i < 40; ++i) {
    Obstacle o{.name = "o" + std::to_string(i), .shape = MeshShape(i % 2 ? ball : box)};
    o.pose.translation() = Eigen::Vector3d(coord(rng), coord(rng), coord(rng));
    // A uniform rotation from the seeded generator (Eigen's UnitRandom draws from std::rand).
    std::normal_distribution<double> gauss;
    Eigen::Quaterniond rotation(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
    o.pose.linear() = rotation.normalized().toRotationMatrix();
    scene->obstacles.push_back(o);
  }
  RobotBody robot{.name = "ball", .shape = MeshShape(SphereMesh(1.0, 16, 32))};
  robot.offset.translation() = Eigen::Vector3d(0.5, 0, 0);
  scene->robot.push_back(robot);
  return scene;
}

// --- box robot against a box obstacle, as primitives and as meshes --------------------------

class BoxPairTest : public ::testing::TestWithParam<std::pair<bool, bool>> {
 protected:
  // Unit cube robot in SE(3); unit cube obstacle centred at (3, 0, 0): faces 1 - s apart when the
  // robot sits at x = 2 - s.
  std::shared_ptr<const CollisionWorld> MakeWorld() const {
    const auto [robot_mesh, obstacle_mesh] = GetParam();
    const Eigen::Vector3d unit = Eigen::Vector3d::Ones();
    auto scene = std::make_shared<Scene>(Scene{
        .space = Space::SE3(Eigen::Vector3d::Constant(-10), Eigen::Vector3d::Constant(10)),
    });
    Obstacle o{.name = "box", .shape = obstacle_mesh ? MeshShape(BoxMesh(unit)) : BoxShape(unit)};
    o.pose.translation() = Eigen::Vector3d(3, 0, 0);
    scene->obstacles.push_back(o);
    scene->robot.push_back(
        RobotBody{.name = "cube", .shape = robot_mesh ? MeshShape(BoxMesh(unit)) : BoxShape(unit)});
    return std::make_shared<CollisionWorld>(scene);
  }
};

Config Se3(double x, double y, double z, double yaw = 0) {
  const Eigen::Quaterniond r(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return Vec({x, y, z, r.x(), r.y(), r.z(), r.w()});
}

TEST_P(BoxPairTest, ValidityAndClearanceMatchTheGap) {
  const auto world = MakeWorld();
  auto context = world->MakeContext();
  for (double gap : {2.0, 0.5, 0.1, 1e-3}) {
    const Config q = Se3(2 - gap, 0, 0);
    EXPECT_TRUE(context->Valid(q)) << gap;
    EXPECT_NEAR(context->Clearance(q), gap, kTolerance) << gap;
  }
  // Edge to edge and corner to corner.
  EXPECT_NEAR(context->Clearance(Se3(1.5, 1.5, 0)), std::sqrt(0.5), kTolerance);
  EXPECT_NEAR(context->Clearance(Se3(1.5, 1.5, 1.5)), std::sqrt(0.75), kTolerance);
  // Turned 45 degrees about Z, the robot reaches sqrt(2)/2 along X.
  EXPECT_NEAR(context->Clearance(Se3(1.0, 0, 0, std::numbers::pi / 4)), 1.5 - std::sqrt(0.5),
              kTolerance);
  for (double overlap : {1e-3, 0.5, 1.0}) {
    const Config q = Se3(2 + overlap, 0, 0);
    EXPECT_FALSE(context->Valid(q)) << overlap;
    EXPECT_EQ(context->Clearance(q), 0.0) << overlap;
  }
  EXPECT_EQ(context->collision_checks(), 7);
  EXPECT_EQ(context->distance_queries(), 10);
}

INSTANTIATE_TEST_SUITE_P(PrimitivesAndMeshes, BoxPairTest,
                         ::testing::Values(std::pair{false, false}, std::pair{true, false},
                                           std::pair{false, true}, std::pair{true, true}),
                         [](const auto& param_info) {
                           return std::string(param_info.param.first ? "MeshRobot" : "BoxRobot") +
                                  (param_info.param.second ? "MeshObstacle" : "BoxObstacle");
                         });

// --- the OMPL circle problem ------------------------------------------------------------------

class CircleSceneTest : public ::testing::TestWithParam<double> {};

TEST_P(CircleSceneTest, ClearanceIsTheAnalyticDistanceToTheNearestDisc) {
  const double robot_radius = GetParam();
  const std::vector<Disc> discs = LoadDiscs();
  ASSERT_EQ(discs.size(), 70u);
  const CollisionWorld world(CircleScene(discs, robot_radius));
  auto context = world.MakeContext();
  std::mt19937_64 rng(42);
  int free = 0, blocked = 0;
  for (int i = 0; i < 3000; ++i) {
    const Config q = world.space().Sample(rng);
    const double expected = AnalyticDiscClearance(discs, robot_radius, q);
    EXPECT_NEAR(context->Clearance(q), expected, kTolerance) << q.transpose();
    if (expected > kTolerance) {
      EXPECT_TRUE(context->Valid(q)) << q.transpose();
      ++free;
    } else if (expected == 0) {
      EXPECT_FALSE(context->Valid(q)) << q.transpose();
      ++blocked;
    }
  }
  EXPECT_GT(free, 100);
  EXPECT_GT(blocked, 100);
  // Disc 1 is centred at (27, 15).
  EXPECT_FALSE(context->Valid(Vec({27, 15})));
  EXPECT_EQ(context->Clearance(Vec({27, 15})), 0.0);
}

INSTANTIATE_TEST_SUITE_P(PointAndDisc, CircleSceneTest, ::testing::Values(0.0, 1.0));

// A square robot turning in the plane among the discs exercises GJK (box against cylinder).
TEST(CircleSceneBoxTest, ClearanceOfATurningSquareIsAnalytic) {
  const std::vector<Disc> discs = LoadDiscs();
  auto scene = std::make_shared<Scene>(*CircleScene(discs, 0.0));
  scene->space = Space::SE2(Eigen::Vector2d(0, -5), Eigen::Vector2d(70, 70));
  scene->robot[0].shape = BoxShape(Eigen::Vector3d(2, 1, 1));
  const CollisionWorld world(scene);
  auto context = world.MakeContext();
  std::mt19937_64 rng(5);
  for (int i = 0; i < 2000; ++i) {
    const Config q = world.space().Sample(rng);
    double expected = std::numeric_limits<double>::infinity();
    const Eigen::Rotation2Dd turn(q[2]);
    for (const Disc& d : discs) {
      // The disc centre in the square's frame, clamped onto the square.
      const Eigen::Vector2d c = turn.inverse() * (Eigen::Vector2d(d.x, d.y) - q.head<2>());
      const Eigen::Vector2d nearest(std::clamp(c.x(), -1.0, 1.0), std::clamp(c.y(), -0.5, 0.5));
      expected = std::min(expected, (c - nearest).norm() - d.r);
    }
    expected = std::max(0.0, expected);
    EXPECT_NEAR(context->Clearance(q), expected, kTolerance) << q.transpose();
    if (expected > kTolerance) {
      EXPECT_TRUE(context->Valid(q)) << q.transpose();
    } else if (expected == 0) {
      EXPECT_FALSE(context->Valid(q)) << q.transpose();
    }
  }
}

// --- self-collision, bounds, radius, validation ---------------------------------------------

std::shared_ptr<const Scene> TwoBoxesScene(bool self_collision, int second_component) {
  const ComponentSpec plane{.type = ComponentType::kRealVector,
                            .dimension = 2,
                            .lower = Eigen::Vector2d(-10, -10),
                            .upper = Eigen::Vector2d(10, 10)};
  auto scene = std::make_shared<Scene>(Scene{.space = Space({plane, plane})});
  scene->robot.push_back(RobotBody{.name = "a", .shape = BoxShape(Eigen::Vector3d::Ones())});
  scene->robot.push_back(RobotBody{
      .name = "b", .shape = BoxShape(Eigen::Vector3d::Ones()), .component = second_component});
  scene->self_collision = self_collision;
  return scene;
}

TEST(CollisionWorldTest, SelfCollisionBetweenBodiesOfDifferentComponents) {
  const CollisionWorld world(TwoBoxesScene(true, 1));
  auto context = world.MakeContext();
  EXPECT_TRUE(context->Valid(Vec({0, 0, 3, 0})));
  EXPECT_NEAR(context->Clearance(Vec({0, 0, 3, 0})), 2.0, kTolerance);
  EXPECT_NEAR(context->Clearance(Vec({0, 0, 2, 2})), std::sqrt(2.0), kTolerance);
  EXPECT_FALSE(context->Valid(Vec({0, 0, 0.5, 0.5})));
  EXPECT_EQ(context->Clearance(Vec({0, 0, 0.5, 0.5})), 0.0);

  const CollisionWorld without(TwoBoxesScene(false, 1));
  auto other = without.MakeContext();
  EXPECT_TRUE(other->Valid(Vec({0, 0, 0.5, 0.5})));
  // Nothing to hit at all: unbounded clearance.
  EXPECT_EQ(other->Clearance(Vec({0, 0, 0.5, 0.5})), std::numeric_limits<double>::infinity());
}

TEST(CollisionWorldTest, BodiesOnOneComponentAreOneRigidBody) {
  const CollisionWorld world(TwoBoxesScene(true, 0));
  auto context = world.MakeContext();
  EXPECT_TRUE(context->Valid(Vec({0, 0, 5, 5})));
}

TEST(CollisionWorldTest, OutOfBoundsIsInvalidWithZeroClearance) {
  const CollisionWorld world(CircleScene(LoadDiscs(), 0.0));
  auto context = world.MakeContext();
  EXPECT_TRUE(context->Valid(Vec({1, 1})));
  EXPECT_FALSE(context->Valid(Vec({-1, 1})));
  EXPECT_FALSE(context->Valid(Vec({1, 70.5})));
  EXPECT_EQ(context->Clearance(Vec({-1, 1})), 0.0);
  EXPECT_EQ(context->collision_checks(), 3);
  EXPECT_EQ(context->distance_queries(), 1);
}

TEST(CollisionWorldTest, BodyRadiusBoundsEveryPointOfTheBody) {
  auto scene = std::make_shared<Scene>(
      Scene{.space = Space::SE3(Eigen::Vector3d::Constant(-5), Eigen::Vector3d::Constant(5))});
  const auto add = [&](Shape shape, const Eigen::Vector3d& offset, double yaw = 0) {
    RobotBody body{.shape = std::move(shape)};
    body.offset.translation() = offset;
    body.offset.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    scene->robot.push_back(body);
  };
  add(BoxShape(Eigen::Vector3d(2, 2, 2)), Eigen::Vector3d(1, 0, 0));
  add(Shape{.type = ShapeType::kSphere, .radius = 0.5}, Eigen::Vector3d(0, 3, 0), 1.0);
  add(Shape{.type = ShapeType::kCylinder, .radius = 1, .length = 2}, Eigen::Vector3d(0, 0, 1));
  add(MeshShape(BoxMesh(Eigen::Vector3d(2, 4, 6))), Eigen::Vector3d::Zero(), 0.3);
  add(Shape{.type = ShapeType::kSphere, .radius = 0}, Eigen::Vector3d::Zero());
  const CollisionWorld world(scene);
  EXPECT_NEAR(world.BodyRadius(0), std::sqrt(4 + 1 + 1), 1e-12);
  EXPECT_NEAR(world.BodyRadius(1), 3.5, 1e-12);
  EXPECT_NEAR(world.BodyRadius(2), std::hypot(1, 2), 1e-12);
  EXPECT_NEAR(world.BodyRadius(3), std::sqrt(1 + 4 + 9), 1e-12);
  EXPECT_EQ(world.BodyRadius(4), 0.0);
  EXPECT_GT(world.memory_bytes(), 0u);
}

TEST(CollisionWorldTest, RejectsAnInvalidSceneNamingTheField) {
  const auto expect_field = [](Scene scene, const std::string& field) {
    try {
      CollisionWorld world(std::make_shared<const Scene>(std::move(scene)));
      ADD_FAILURE() << "expected InputError for " << field;
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), field);
    }
  };
  Scene base = *TwoBoxesScene(true, 1);
  Scene empty = base;
  empty.robot.clear();
  expect_field(empty, "robot");
  Scene bad_component = base;
  bad_component.robot[1].component = 2;
  expect_field(bad_component, "robot[1].component");
  Scene bad_box = base;
  bad_box.obstacles.push_back(Obstacle{.shape = BoxShape(Eigen::Vector3d(1, -1, 1))});
  expect_field(bad_box, "obstacles[0].shape.box_size[1]");
  Scene bad_sphere = base;
  bad_sphere.robot[0].shape = Shape{.type = ShapeType::kSphere, .radius = -1};
  expect_field(bad_sphere, "robot[0].shape.radius");
  Scene no_mesh = base;
  no_mesh.robot[0].shape = Shape{.type = ShapeType::kMesh};
  expect_field(no_mesh, "robot[0].shape.mesh");
  Scene so3_only = base;
  so3_only.space = Space({ComponentSpec{.type = ComponentType::kRealVector,
                                        .dimension = 4,
                                        .lower = Eigen::Vector4d::Zero(),
                                        .upper = Eigen::Vector4d::Ones()}});
  so3_only.robot.resize(1);
  expect_field(so3_only, "robot[0].component");
}

// Each pair's traversal starts from the clearance found so far and prunes what lies farther:
// the result must still be the exact least distance, the one the obstacles give one at a time.
TEST(CollisionWorldTest, ClearanceAmongManyMeshesIsTheLeastOfEachObstacleAlone) {
  const std::shared_ptr<const Scene> scene = MeshScene();
  const CollisionWorld world(scene);
  std::vector<std::unique_ptr<CollisionWorld>> alone;
  for (const Obstacle& o : scene->obstacles) {
    auto one = std::make_shared<Scene>(*scene);
    one->obstacles = {o};
    alone.push_back(std::make_unique<CollisionWorld>(one));
  }
  auto context = world.MakeContext();
  std::vector<std::unique_ptr<CollisionContext>> alone_contexts;
  for (const auto& w : alone) alone_contexts.push_back(w->MakeContext());
  std::mt19937_64 rng(11);
  int free = 0;
  for (int i = 0; i < 100; ++i) {
    const Config q = world.space().Sample(rng);
    double least = std::numeric_limits<double>::infinity();
    for (const auto& c : alone_contexts) least = std::min(least, c->Clearance(q));
    EXPECT_NEAR(context->Clearance(q), least, 1e-12) << q.transpose();
    free += least > 0;
  }
  EXPECT_GT(free, 25);
}

// --- witnesses --------------------------------------------------------------------------------

std::vector<Eigen::Isometry3d> BodyPoses(const CollisionWorld& world, const Config& q) {
  std::vector<Eigen::Isometry3d> poses;
  for (size_t b = 0; b < world.scene().robot.size(); ++b) {
    poses.push_back(world.BodyPose(static_cast<int>(b), q));
  }
  return poses;
}

// Where a clearance was found: the witness's points are as far apart as the clearance at the
// configuration queried, and at any other configuration at least as far apart as the clearance
// there (the upper bound lazy evaluation takes). Asking for the witness leaves the clearance as
// it was. Returns how many witnesses pointed at another body.
int ExpectWitnessesBoundClearance(const CollisionWorld& world, uint64_t seed) {
  auto context = world.MakeContext();
  std::mt19937_64 rng(seed);
  int witnessed = 0;
  int to_bodies = 0;
  for (int i = 0; i < 60; ++i) {
    const Config q = world.space().Sample(rng);
    ClearanceWitness witness;
    const double clearance = context->Clearance(q, &witness);
    EXPECT_EQ(clearance, context->Clearance(q)) << q.transpose();
    if (!(clearance > 0) || !std::isfinite(clearance)) {
      EXPECT_EQ(witness.body, -1) << q.transpose();
      continue;
    }
    if (witness.body < 0) {
      ADD_FAILURE() << "no witness at " << q.transpose();
      continue;
    }
    ++witnessed;
    to_bodies += witness.other_body >= 0;
    const double apart = CollisionWorld::WitnessDistance(witness, BodyPoses(world, q));
    EXPECT_GE(apart, clearance) << q.transpose();
    EXPECT_NEAR(apart, clearance, 1e-6 * (1 + clearance)) << q.transpose();
    // Elsewhere: along a motion from q, and anywhere.
    const Config far = world.space().Sample(rng);
    for (int j = 1; j <= 10; ++j) {
      const Config other = world.space().Interpolate(q, far, j / 10.0);
      const double there = context->Clearance(other);
      const double bound = CollisionWorld::WitnessDistance(witness, BodyPoses(world, other));
      EXPECT_GE(bound, there) << q.transpose() << " -> " << other.transpose();
    }
  }
  EXPECT_GT(witnessed, 20);
  return to_bodies;
}

TEST(CollisionWorldTest, WitnessesOfMeshClearancesBoundItElsewhere) {
  const CollisionWorld world(MeshScene());
  EXPECT_EQ(ExpectWitnessesBoundClearance(world, 3), 0);
}

TEST(CollisionWorldTest, WitnessesOfATurningBoxAmongDiscsBoundItElsewhere) {
  auto scene = std::make_shared<Scene>(*CircleScene(LoadDiscs(), 0.0));
  scene->space = Space::SE2(Eigen::Vector2d(0, -5), Eigen::Vector2d(70, 70));
  scene->robot[0].shape = BoxShape(Eigen::Vector3d(2, 1, 1));
  scene->robot[0].offset.translation() = Eigen::Vector3d(0.5, 0, 0);
  const CollisionWorld world(scene);
  EXPECT_EQ(ExpectWitnessesBoundClearance(world, 4), 0);
}

// Sphere against cylinder and sphere against box: closed-form distances in FCL, not GJK.
TEST(CollisionWorldTest, WitnessesOfADiscAmongDiscsAndBoxesBoundItElsewhere) {
  auto scene = std::make_shared<Scene>(*CircleScene(LoadDiscs(), 1.0));
  for (int i = 0; i < 6; ++i) {
    Obstacle box{.shape = BoxShape(Eigen::Vector3d(4, 2, 2))};
    box.pose.translation() = Eigen::Vector3d(10 * i + 5, 30, 0);
    box.pose.linear() = Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    scene->obstacles.push_back(box);
  }
  const CollisionWorld world(scene);
  EXPECT_EQ(ExpectWitnessesBoundClearance(world, 6), 0);
}

// Between two bodies the witness's second point moves with the second body.
TEST(CollisionWorldTest, WitnessesBetweenRobotBodiesMoveWithBoth) {
  const CollisionWorld world(TwoBoxesScene(true, 1));
  EXPECT_GT(ExpectWitnessesBoundClearance(world, 5), 20);
}

// --- threads --------------------------------------------------------------------------------

struct Answers {
  std::vector<char> valid;
  std::vector<double> clearance;
};

Answers Run(const CollisionWorld& world, const std::vector<Config>& configs, bool reversed) {
  auto context = world.MakeContext();
  Answers a{std::vector<char>(configs.size()), std::vector<double>(configs.size())};
  for (size_t k = 0; k < configs.size(); ++k) {
    const size_t i = reversed ? configs.size() - 1 - k : k;
    a.valid[i] = context->Valid(configs[i]);
    a.clearance[i] = context->Clearance(configs[i]);
  }
  return a;
}

void ExpectTwoThreadsMatchOne(const CollisionWorld& world, int count) {
  std::mt19937_64 rng(2024);
  std::vector<Config> configs;
  for (int i = 0; i < count; ++i) configs.push_back(world.space().Sample(rng));
  const Answers serial = Run(world, configs, false);
  Answers first, second;
  std::thread t1([&] { first = Run(world, configs, false); });
  std::thread t2([&] { second = Run(world, configs, true); });
  t1.join();
  t2.join();
  EXPECT_EQ(first.valid, serial.valid);
  EXPECT_EQ(second.valid, serial.valid);
  EXPECT_EQ(first.clearance, serial.clearance);
  EXPECT_EQ(second.clearance, serial.clearance);
  const auto invalid = std::count(serial.valid.begin(), serial.valid.end(), 0);
  EXPECT_GT(invalid, 0);
  EXPECT_LT(invalid, count);
}

TEST(CollisionWorldThreadTest, TwoThreadsOnTheCircleSceneAgreeWithOne) {
  const CollisionWorld world(CircleScene(LoadDiscs(), 0.5));
  ExpectTwoThreadsMatchOne(world, 4000);
}

TEST(CollisionWorldThreadTest, TwoThreadsOnSharedMeshesAgreeWithOne) {
  const CollisionWorld world(MeshScene());
  ExpectTwoThreadsMatchOne(world, 600);
}

}  // namespace
}  // namespace hgraph
