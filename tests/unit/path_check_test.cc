// CheckPaths, the check behind `hgraph check` and the CheckPaths RPC: it must agree with what a
// merge reports for its inputs, and its certified mode must reject what the sampled check only
// misses between two samples.
#include "core/merge/path_check.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "tests/unit/test_scenes.h"

namespace hgraph {
namespace {

Config Vec(double x, double y) { return Eigen::Vector2d(x, y); }

// A point robot in [0, 10]^2 (MaxExtent = 10 sqrt 2) and one disc of the given radius.
std::shared_ptr<const CollisionWorld> DiscWorld(double x, double y, double radius) {
  auto scene = std::make_shared<Scene>(Scene{
      .name = "disc",
      .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)),
  });
  Obstacle disc{.name = "disc",
                .shape = Shape{.type = ShapeType::kCylinder, .radius = radius, .length = 1}};
  disc.pose.translation() = Eigen::Vector3d(x, y, 0);
  scene->obstacles.push_back(disc);
  scene->robot.push_back(RobotBody{.shape = Shape{.type = ShapeType::kSphere, .radius = 0}});
  return std::make_shared<CollisionWorld>(scene);
}

PathCheckResult Check(const MotionChecker& checker, std::vector<InputPath> paths,
                      CheckMode mode = CheckMode::kCertified) {
  return CheckPaths(checker, PathCheckRequest{.paths = std::move(paths), .mode = mode});
}

TEST(PathCheckTest, EdgeGrazingADiscBetweenSamplesFailsOnlyTheCertifiedCheck) {
  // At resolution 0.5 the edge is sampled at x = 1, 5 and 9, each 2 away from the disc; the
  // straight motion cuts a chord of it at x = 3 (it passes 0.3 from the centre, radius 0.5).
  const LocalPlanner planner(DiscWorld(3, 5.3, 0.5), {.resolution = 0.5});
  const InputPath path{.name = "grazing", .waypoints = {Vec(1, 5), Vec(9, 5)}};
  ASSERT_EQ(planner.SampleCount(8.0), 3);

  const PathCheckResult sampled = Check(planner, {path}, CheckMode::kSampled);
  ASSERT_EQ(sampled.paths.size(), 1u);
  EXPECT_TRUE(sampled.paths[0].valid);
  EXPECT_FALSE(sampled.paths[0].certified);
  EXPECT_FALSE(sampled.paths[0].quality.has_clearance);
  EXPECT_DOUBLE_EQ(sampled.paths[0].quality.length, 8.0);
  EXPECT_EQ(sampled.collision_checks, 3);
  EXPECT_EQ(sampled.distance_queries, 0);

  const PathCheckResult certified = Check(planner, {path});
  const InputReport& report = certified.paths.at(0);
  EXPECT_FALSE(report.valid);
  EXPECT_EQ(report.name, "grazing");
  EXPECT_EQ(report.invalid_edge, 0);
  EXPECT_EQ(report.invalid_cause, InvalidCause::kCollision);
  EXPECT_FALSE(report.certified);
  // Refinement halves [0, 0.5] and then [0, 0.25]: the first midpoint inside the disc is t = 0.25
  // (x = 3).
  EXPECT_DOUBLE_EQ(report.invalid_at, 0.25);
  EXPECT_EQ(report.invalid_reason, "edge 0 -> 1 is in collision at t=0.25");
  EXPECT_DOUBLE_EQ(report.quality.length, 8.0);
  EXPECT_EQ(report.quality.min_clearance, 0);
  EXPECT_GT(certified.distance_queries, 0);
}

TEST(PathCheckTest, FirstInvalidEdgeLeavingTheBoundsIsNamed) {
  const LocalPlanner planner(DiscWorld(5, 5, 1), {.resolution = 0.01});
  const InputPath path{.waypoints = {Vec(1, 1), Vec(2, 1), Vec(11, 1), Vec(5, 5)}};
  const PathCheckResult result = Check(planner, {path});
  const InputReport& report = result.paths.at(0);
  EXPECT_EQ(report.name, "path0");
  EXPECT_EQ(report.waypoints, 4);
  EXPECT_FALSE(report.valid);
  EXPECT_EQ(report.invalid_edge, 1);
  EXPECT_EQ(report.invalid_cause, InvalidCause::kOutOfBounds);
  EXPECT_EQ(report.invalid_at, 1.0);  // the end state is checked first
  EXPECT_EQ(report.invalid_reason, "edge 1 -> 2 leaves the space's bounds at t=1");
}

TEST(PathCheckTest, OneWaypointIsCheckedWhereItStands) {
  const auto world = DiscWorld(5, 5, 1);
  const LocalPlanner planner(world, {.resolution = 0.01});
  const PathCheckResult result =
      Check(planner, {InputPath{.name = "free", .waypoints = {Vec(1, 5)}},
                      InputPath{.name = "inside", .waypoints = {Vec(5, 5.5)}}});
  const InputReport& free = result.paths.at(0);
  EXPECT_TRUE(free.valid);
  EXPECT_TRUE(free.certified);
  EXPECT_EQ(free.quality.length, 0);
  EXPECT_TRUE(free.quality.has_clearance);
  EXPECT_NEAR(free.quality.min_clearance, 3.0, 1e-4);
  EXPECT_NEAR(free.quality.avg_clearance, 3.0, 1e-4);
  const InputReport& inside = result.paths.at(1);
  EXPECT_FALSE(inside.valid);
  EXPECT_EQ(inside.invalid_edge, 0);
  EXPECT_EQ(inside.invalid_reason, "waypoint 0 is in collision");
}

// The point of CheckPaths: it reports exactly what a merge reports for the same inputs.
TEST(PathCheckTest, AgreesWithTheMergesInputReports) {
  const LocalPlanner planner(std::make_shared<CollisionWorld>(testing::CirclesScene()));
  std::vector<InputPath> inputs = testing::CirclePaths();
  inputs.push_back(InputPath{
      .name = "straight", .waypoints = {inputs[0].waypoints.front(), inputs[0].waypoints.back()}});
  const MeasureSpec measure{.type = MeasureType::kInverseClearance, .k = 2};
  const MergeResult merged =
      Merge(planner,
            MergeRequest{.paths = inputs, .measure = measure, .options = {.report_inputs = true}});
  const PathCheckResult checked =
      CheckPaths(planner, PathCheckRequest{.paths = inputs, .k = 2, .threads = 2});
  ASSERT_EQ(checked.paths.size(), merged.inputs.size());
  for (size_t p = 0; p < inputs.size(); ++p) {
    const InputReport& a = checked.paths[p];
    const InputReport& b = merged.inputs[p];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.valid, b.valid) << a.name;
    EXPECT_EQ(a.certified, b.certified) << a.name;
    EXPECT_EQ(a.invalid_edge, b.invalid_edge) << a.name;
    EXPECT_EQ(a.invalid_at, b.invalid_at) << a.name;
    EXPECT_EQ(a.invalid_reason, b.invalid_reason) << a.name;
    EXPECT_EQ(a.quality.length, b.quality.length) << a.name;
    EXPECT_EQ(a.quality.min_clearance, b.quality.min_clearance) << a.name;
    EXPECT_EQ(a.quality.avg_clearance, b.quality.avg_clearance) << a.name;
    EXPECT_EQ(a.quality.inverse_clearance, b.quality.inverse_clearance) << a.name;
    EXPECT_EQ(a.quality.k, 2);
  }
  EXPECT_TRUE(checked.paths[0].valid);
  EXPECT_FALSE(checked.paths[2].valid);
  EXPECT_EQ(checked.paths[2].invalid_cause, InvalidCause::kCollision);

  // The merged path passes the check with the quality the merge reported for it.
  const PathCheckResult output =
      CheckPaths(planner, PathCheckRequest{.paths = {merged.path}, .k = 2});
  ASSERT_TRUE(output.paths.at(0).valid) << output.paths[0].invalid_reason;
  EXPECT_NEAR(output.paths[0].quality.length, merged.quality.length, 1e-9);
  EXPECT_NEAR(output.paths[0].quality.min_clearance, merged.quality.min_clearance, 1e-6);
}

TEST(PathCheckTest, CountsDoNotDependOnTheThreads) {
  const LocalPlanner planner(std::make_shared<CollisionWorld>(testing::CirclesScene()));
  const PathCheckResult one =
      CheckPaths(planner, PathCheckRequest{.paths = testing::CirclePaths(), .threads = 1});
  const PathCheckResult two =
      CheckPaths(planner, PathCheckRequest{.paths = testing::CirclePaths(), .threads = 2});
  EXPECT_EQ(one.collision_checks, two.collision_checks);
  EXPECT_EQ(one.distance_queries, two.distance_queries);
  EXPECT_GT(one.distance_queries, 0);
  EXPECT_EQ(one.edges_checked, two.edges_checked);
}

std::string FieldOf(const MotionChecker& checker, const PathCheckRequest& request) {
  try {
    CheckPaths(checker, request);
  } catch (const InputError& e) {
    return e.field();
  }
  return "(no error)";
}

TEST(PathCheckTest, BadInputNamesTheField) {
  const LocalPlanner planner(DiscWorld(5, 5, 1));
  const InputPath ok{.waypoints = {Vec(1, 1), Vec(2, 2)}};
  EXPECT_EQ(FieldOf(planner, {.paths = {}}), "paths");
  EXPECT_EQ(FieldOf(planner, {.paths = {ok, InputPath{.name = "empty"}}}), "paths[1].waypoints");
  InputPath bad = ok;
  bad.waypoints[1][1] = std::nan("");
  EXPECT_EQ(FieldOf(planner, {.paths = {ok, bad}, .field = "paths.paths"}),
            "paths.paths[1].waypoints[1][1]");
  bad.waypoints[1] = Eigen::Vector3d(1, 2, 3);
  EXPECT_EQ(FieldOf(planner, {.paths = {bad}}), "paths[0].waypoints[1]");
  EXPECT_EQ(FieldOf(planner, {.paths = {ok}, .k = -1}), "k");
  EXPECT_EQ(FieldOf(planner, {.paths = {ok}, .threads = -1}), "threads");
}

TEST(PathCheckTest, CancelStopsTheCheck) {
  const LocalPlanner planner(DiscWorld(5, 5, 1));
  PathCheckRequest request{.paths = {InputPath{.waypoints = {Vec(1, 1), Vec(2, 2)}}}};
  request.cancel.Cancel();
  try {
    CheckPaths(planner, request);
    FAIL() << "expected cancellation";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled);
  }
}

}  // namespace
}  // namespace hgraph
