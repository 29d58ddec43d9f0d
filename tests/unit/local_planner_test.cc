#include "core/motion/local_planner.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "core/adapter/scene_proto.h"
#include "core/common/error.h"
#include "core/common/limits.h"
#include "core/common/progress.h"
#include "core/measure/measure.h"

namespace hgraph {
namespace {

Config Vec(std::initializer_list<double> values) {
  Config q(static_cast<int>(values.size()));
  int i = 0;
  for (double v : values) q[i++] = v;
  return q;
}

Obstacle Box(double x, double y, double sx, double sy) {
  Obstacle o{.shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(sx, sy, 1)}};
  o.pose.translation() = Eigen::Vector3d(x, y, 0);
  return o;
}

// A point robot in [0, 10]^2 (MaxExtent = 10 sqrt 2) with box obstacles.
std::shared_ptr<const CollisionWorld> PointWorld(std::vector<Obstacle> obstacles) {
  auto scene = std::make_shared<Scene>(Scene{
      .name = "boxes",
      .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)),
      .obstacles = std::move(obstacles),
  });
  scene->robot.push_back(RobotBody{.shape = Shape{.type = ShapeType::kSphere, .radius = 0}});
  return std::make_shared<CollisionWorld>(scene);
}

// The OMPL circle discs, with a 2 x 0.6 rectangle turning in SE(2): the certificate must account
// for rotation (BodyRadius), not only translation.
std::shared_ptr<const CollisionWorld> CircleWorld() {
  const std::string file = std::string(HGRAPH_TEST_DATA_DIR) + "/ompl-2d/circle_obstacles.txt";
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot open test data file " + file);
  std::string line;
  std::getline(in, line);
  std::getline(in, line);
  auto scene = std::make_shared<Scene>(Scene{
      .name = "circles",
      .space = Space::SE2(Eigen::Vector2d(0, -5), Eigen::Vector2d(70, 70)),
  });
  int id;
  double x, y, r;
  while (in >> id >> x >> y >> r) {
    Obstacle o{.shape = Shape{.type = ShapeType::kCylinder, .radius = r, .length = 2}};
    o.pose.translation() = Eigen::Vector3d(x, y, 0);
    scene->obstacles.push_back(o);
  }
  RobotBody body{.shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(2, 0.6, 1)}};
  body.offset.translation() = Eigen::Vector3d(0.5, 0, 0);  // turns about a point off its centre
  scene->robot.push_back(body);
  return std::make_shared<CollisionWorld>(scene);
}

EdgeReport Check(const LocalPlanner& planner, const Config& from, const Config& to,
                 bool need_clearance = false) {
  return planner.CheckEdge({.from = &from,
                            .to = &to,
                            .proof = need_clearance ? EdgeProof::kProfile : EdgeProof::kSamples});
}

// Short random motions of the circle world (a fifth of a random step) whose clearance profile is
// valid and certified: visit(i, from, to, profile) for up to 60 of 400 draws; returns how many.
template <typename Visit>
int ForShortFreeMotions(const LocalPlanner& planner, uint64_t seed, Visit visit) {
  const Space& space = planner.space();
  std::mt19937_64 rng(seed);
  int visited = 0;
  for (int i = 0; i < 400 && visited < 60; ++i) {
    const Config from = space.Sample(rng);
    Config to = space.Sample(rng);
    to.head<2>() = from.head<2>() + 0.2 * (to.head<2>() - from.head<2>());
    const EdgeReport profile = Check(planner, from, to, true);
    if (profile.state != EdgeState::kValid || !profile.certified) continue;
    ++visited;
    visit(i, from, to, profile);
  }
  return visited;
}

TEST(LocalPlannerTest, RejectsBadResolution) {
  const auto world = PointWorld({});
  for (double bad : {0.0, -0.1, std::nan("")}) {
    try {
      LocalPlanner planner(world, {.resolution = bad});
      ADD_FAILURE() << bad;
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), "resolution");
    }
  }
}

TEST(LocalPlannerTest, EdgeThroughAnObstacleIsInvalidInside) {
  const LocalPlanner planner(PointWorld({Box(5, 5, 2, 2)}));
  const Config from = Vec({1, 5}), to = Vec({9, 5});
  const EdgeReport report = Check(planner, from, to);
  EXPECT_EQ(report.state, EdgeState::kInvalid);
  EXPECT_GT(report.invalid_at, 0.0);
  EXPECT_LT(report.invalid_at, 1.0);
  const double x = 1 + 8 * report.invalid_at;  // where the blocked sample lies
  EXPECT_GE(x, 4.0);
  EXPECT_LE(x, 6.0);
  EXPECT_DOUBLE_EQ(report.length, 8.0);
  // The first interior sample checked is the grid point nearest the middle (29 of 57 segments),
  // inside the box: the two ends and one more check.
  EXPECT_EQ(report.collision_checks, 3);
  EXPECT_DOUBLE_EQ(report.invalid_at, 29.0 / 57.0);
}

TEST(LocalPlannerTest, FreeEdgeIsValidAndChecksEverySample) {
  const LocalPlanner planner(PointWorld({Box(5, 5, 2, 2)}), {.resolution = 0.01});
  const Config from = Vec({1, 1}), to = Vec({9, 1});
  const EdgeReport report = Check(planner, from, to);
  EXPECT_EQ(report.state, EdgeState::kValid);
  EXPECT_EQ(report.invalid_at, -1);
  EXPECT_FALSE(report.has_clearance);
  EXPECT_TRUE(report.profile.empty());
  // Step 0.01 * 10 sqrt 2 = 0.1414: 8 / 0.1414 -> 57 segments, 58 samples.
  EXPECT_EQ(planner.SampleCount(8.0), 58);
  EXPECT_EQ(report.collision_checks, 58);
  EXPECT_EQ(report.distance_queries, 0);
}

TEST(LocalPlannerTest, SampleCountFollowsResolution) {
  const auto world = PointWorld({});
  const double extent = world->space().MaxExtent();
  for (double resolution : {0.5, 0.1, 0.01, 0.003}) {
    const LocalPlanner planner(world, {.resolution = resolution});
    const double step = resolution * extent;
    EXPECT_EQ(planner.SampleCount(0.0), 2);
    EXPECT_EQ(planner.SampleCount(0.5 * step), 2);
    EXPECT_EQ(planner.SampleCount(3 * step * (1 - 1e-12)), 4);
    EXPECT_EQ(planner.SampleCount(3 * step * (1 + 1e-9)), 5);
    const Config from = Vec({0.5, 0.5}), to = Vec({9.5, 9.5});
    const EdgeReport report = Check(planner, from, to);
    EXPECT_EQ(report.collision_checks, planner.SampleCount(report.length)) << resolution;
  }
}

// A check at the finest resolution allowed (over half a million samples here) stops when its
// caller does: a cancelled merge or a server shutting down does not wait for it.
TEST(LocalPlannerTest, AStoppedCallerStopsALongCheck) {
  const LocalPlanner planner(PointWorld({Box(5, 5, 2, 2)}), {.resolution = limits::kMinResolution});
  const Config from = Vec({1, 1}), to = Vec({9, 1});
  ASSERT_GT(planner.SampleCount(8.0), 500000);
  for (EdgeProof proof : {EdgeProof::kSamples, EdgeProof::kProfile}) {
    CancelToken cancel;
    cancel.Cancel();
    try {
      planner.CheckEdge({.from = &from, .to = &to, .proof = proof, .cancel = &cancel});
      ADD_FAILURE() << "a cancelled check ran to its end";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kCancelled);
    }
    // Without a token the same check runs to its end (the samples only: a profile is slower).
    if (proof == EdgeProof::kSamples) {
      EXPECT_EQ(planner.CheckEdge({.from = &from, .to = &to, .proof = proof}).state,
                EdgeState::kValid);
    }
  }
}

TEST(LocalPlannerTest, EndStateIsCheckedFirst) {
  const LocalPlanner planner(PointWorld({Box(5, 5, 2, 2)}), {.resolution = 0.001});
  const Config free = Vec({1, 5}), blocked = Vec({5, 5});
  const EdgeReport into = Check(planner, free, blocked, true);
  EXPECT_EQ(into.state, EdgeState::kInvalid);
  EXPECT_EQ(into.invalid_at, 1.0);
  EXPECT_LE(into.collision_checks, 2);
  EXPECT_EQ(into.distance_queries, 0);
  const EdgeReport out_of = Check(planner, blocked, free, true);
  EXPECT_EQ(out_of.state, EdgeState::kInvalid);
  EXPECT_EQ(out_of.invalid_at, 0.0);
  EXPECT_LE(out_of.collision_checks, 2);
}

TEST(LocalPlannerTest, ClearanceProfileIsSortedWithBothEnds) {
  const auto world = PointWorld({Box(5, 5, 2, 2)});
  const LocalPlanner planner(world, {.resolution = 0.05});
  const Config from = Vec({1, 2}), to = Vec({9, 3.5});
  const EdgeReport report = Check(planner, from, to, true);
  ASSERT_EQ(report.state, EdgeState::kValid);
  ASSERT_TRUE(report.has_clearance);
  ASSERT_GE(report.profile.size(), 2u);
  EXPECT_EQ(report.profile.front().t, 0.0);
  EXPECT_EQ(report.profile.back().t, 1.0);
  auto context = world->MakeContext();
  for (size_t i = 0; i < report.profile.size(); ++i) {
    if (i > 0) {
      EXPECT_LT(report.profile[i - 1].t, report.profile[i].t);
    }
    const ClearanceSample& s = report.profile[i];
    EXPECT_GT(s.clearance, 0.0);
    EXPECT_DOUBLE_EQ(s.clearance, context->Clearance(world->space().Interpolate(from, to, s.t)));
  }
  EXPECT_EQ(report.distance_queries, static_cast<int64_t>(report.profile.size()));
  EXPECT_GE(report.profile.size(), static_cast<size_t>(planner.SampleCount(report.length)));
}

TEST(LocalPlannerTest, EdgesInOpenSpaceAreCertifiedWithoutRefinement) {
  const LocalPlanner planner(PointWorld({Box(9.5, 9.5, 0.5, 0.5)}), {.resolution = 0.02});
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> coord(0.5, 6);
  for (int i = 0; i < 50; ++i) {
    const Config from = Vec({coord(rng), coord(rng)}), to = Vec({coord(rng), coord(rng)});
    const EdgeReport report = Check(planner, from, to, true);
    ASSERT_EQ(report.state, EdgeState::kValid);
    EXPECT_TRUE(report.certified);
    EXPECT_EQ(report.profile.size(), static_cast<size_t>(planner.SampleCount(report.length)));
  }
}

TEST(LocalPlannerTest, ThinObstacleMissedBySamplesIsCaughtByRefinement) {
  // A wall 0.05 thick at x = 3; at resolution 0.5 the samples of the edge are x = 1, 5, 9.
  const LocalPlanner planner(PointWorld({Box(3, 5, 0.05, 4)}), {.resolution = 0.5});
  const Config from = Vec({1, 5}), to = Vec({9, 5});
  ASSERT_EQ(planner.SampleCount(8.0), 3);
  const EdgeReport unchecked_between = Check(planner, from, to, false);
  EXPECT_EQ(unchecked_between.state, EdgeState::kValid);
  const EdgeReport refined = Check(planner, from, to, true);
  EXPECT_EQ(refined.state, EdgeState::kInvalid);
  EXPECT_DOUBLE_EQ(refined.invalid_at, 0.25);
  EXPECT_FALSE(refined.has_clearance);
  EXPECT_FALSE(refined.certified);
}

// MotionBound on random motions of robots that turn (SE(2) and SE(3) meshes, the circle world's
// off-centre box): every point of the robot's hull (mesh vertices, box corners) travels no farther
// than the bound, measured along its path in 400 steps; and the bound, which uses the distance
// from each motion's rotation axis, is below the radius about the frame's origin on most
// motions that turn, so that certificates take longer steps.
TEST(LocalPlannerTest, MotionBoundCoversEveryPointsPathAndUsesTheTurnsAxis) {
  const std::string root = HGRAPH_SOURCE_DIR;
  std::vector<std::shared_ptr<const CollisionWorld>> worlds = {CircleWorld()};
  for (const char* name : {"home", "twisty", "car_maze"}) {
    worlds.push_back(std::make_shared<const CollisionWorld>(
        LoadSceneFile(root + "/tests/bench/scenes/" + name + "/scene.json")));
  }
  for (const auto& world : worlds) {
    SCOPED_TRACE(world->scene().name);
    const LocalPlanner planner(world, {});
    const Space& space = world->space();
    std::vector<std::vector<Eigen::Vector3d>> hull;
    for (const RobotBody& body : world->scene().robot) {
      hull.emplace_back();
      if (body.shape.type == ShapeType::kMesh) {
        hull.back() = body.shape.mesh->vertices;
      } else if (body.shape.type == ShapeType::kBox) {
        for (int corner = 0; corner < 8; ++corner) {
          hull.back().push_back(Eigen::Vector3d(corner & 1 ? 0.5 : -0.5, corner & 2 ? 0.5 : -0.5,
                                                corner & 4 ? 0.5 : -0.5)
                                    .cwiseProduct(body.shape.box_size));
        }
      }
    }
    std::mt19937_64 rng(7);
    int tighter = 0;
    constexpr int kMotions = 60;
    for (int m = 0; m < kMotions; ++m) {
      const Config a = space.Sample(rng);
      // Short and long turns, both ways round.
      const Config b = space.Interpolate(a, space.Sample(rng), m % 2 ? 0.1 : 1.0);
      const double bound = planner.MotionBound(a, b);
      double radius_bound = 0;
      for (size_t i = 0; i < hull.size(); ++i) {
        const int c = world->scene().robot[i].component;
        radius_bound += space.TranslationDistance(c, a, b) +
                        world->BodyRadius(static_cast<int>(i)) * space.RotationAngle(c, a, b);
      }
      EXPECT_LE(bound, radius_bound * (1 + 1e-12) + 1e-12);
      if (bound < radius_bound * (1 - 1e-3)) ++tighter;
      constexpr int kSteps = 400;
      for (size_t i = 0; i < hull.size(); ++i) {
        std::vector<double> travelled(hull[i].size(), 0);
        Eigen::Isometry3d previous = world->BodyPose(static_cast<int>(i), a);
        for (int k = 1; k <= kSteps; ++k) {
          const Eigen::Isometry3d pose =
              world->BodyPose(static_cast<int>(i), space.Interpolate(a, b, k / double(kSteps)));
          for (size_t v = 0; v < hull[i].size(); ++v) {
            travelled[v] += (pose * hull[i][v] - previous * hull[i][v]).norm();
          }
          previous = pose;
        }
        for (double d : travelled) ASSERT_LE(d, bound * (1 + 1e-9) + 1e-12) << "motion " << m;
      }
    }
    EXPECT_GT(tighter, kMotions / 2);
  }
}

TEST(LocalPlannerTest, CertifiedEdgesAreFreeWhenCheckedDensely) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.02});
  auto dense = world->MakeContext();
  std::mt19937_64 rng(3);
  int certified = 0, uncertified = 0, caught = 0;
  for (int i = 0; i < 300; ++i) {
    const Config from = world->space().Sample(rng);
    // Short hops, so that most edges are valid.
    Config to = world->space().Sample(rng);
    to.head<2>() = from.head<2>() + 0.15 * (to.head<2>() - from.head<2>());
    const EdgeReport report = Check(planner, from, to, true);
    const EdgeReport plain = Check(planner, from, to, false);
    if (plain.state == EdgeState::kValid && report.state == EdgeState::kInvalid) ++caught;
    if (report.state != EdgeState::kValid) continue;
    if (!report.certified) {
      ++uncertified;
      continue;
    }
    ++certified;
    for (int k = 0; k <= 2000; ++k) {
      ASSERT_TRUE(dense->Valid(world->space().Interpolate(from, to, k / 2000.0)))
          << "certified edge " << i << " collides at t = " << k / 2000.0;
    }
  }
  EXPECT_GT(certified, 30);
  std::printf("[ circles ] %d certified, %d valid but uncertified, %d caught only by refinement\n",
              certified, uncertified, caught);
}

// certify: the same verdict as the clearance check on every edge, proven free by dense checking
// where it says certified, and far fewer distance queries in open space.
TEST(LocalPlannerTest, CertifyAgreesWithTheClearanceCheckAndCostsLess) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.02});
  auto dense = world->MakeContext();
  std::mt19937_64 rng(5);
  int valid = 0, invalid = 0;
  int64_t profile_queries = 0, certify_queries = 0;
  for (int i = 0; i < 300; ++i) {
    const Config from = world->space().Sample(rng);
    Config to = world->space().Sample(rng);
    to.head<2>() = from.head<2>() + 0.15 * (to.head<2>() - from.head<2>());
    const EdgeReport profile = Check(planner, from, to, true);
    const EdgeReport certify =
        planner.CheckEdge({.from = &from, .to = &to, .proof = EdgeProof::kCertificate});
    ASSERT_EQ(certify.state, profile.state) << "edge " << i;
    if (certify.state != EdgeState::kValid) {
      ++invalid;
      continue;
    }
    ++valid;
    profile_queries += profile.distance_queries;
    certify_queries += certify.distance_queries;
    EXPECT_EQ(certify.certified, profile.certified) << "edge " << i;
    if (!certify.certified) continue;
    for (int k = 0; k <= 2000; ++k) {
      ASSERT_TRUE(dense->Valid(world->space().Interpolate(from, to, k / 2000.0)))
          << "certified edge " << i << " collides at t = " << k / 2000.0;
    }
  }
  EXPECT_GT(valid, 30);
  EXPECT_GT(invalid, 10);
  EXPECT_LE(certify_queries, profile_queries);
  std::printf("[ circles ] %d valid, %d invalid; distance queries: profile %lld, certify %lld\n",
              valid, invalid, static_cast<long long>(profile_queries),
              static_cast<long long>(certify_queries));

  // Long edges in open space: a handful of queries instead of one per sample.
  const LocalPlanner open(PointWorld({Box(9.5, 9.5, 0.5, 0.5)}), {.resolution = 0.01});
  std::uniform_real_distribution<double> coord(0.5, 6);
  for (int i = 0; i < 20; ++i) {
    const Config from = Vec({coord(rng), coord(rng)}), to = Vec({coord(rng), coord(rng)});
    const EdgeReport report =
        open.CheckEdge({.from = &from, .to = &to, .proof = EdgeProof::kCertificate});
    ASSERT_EQ(report.state, EdgeState::kValid);
    EXPECT_TRUE(report.certified);
    EXPECT_LT(report.distance_queries, 12);
    EXPECT_FALSE(report.has_clearance);
  }

  // The thin wall between samples: certify catches it as the clearance check does.
  const LocalPlanner coarse(PointWorld({Box(3, 5, 0.05, 4)}), {.resolution = 0.5});
  const Config a = Vec({1, 5}), b = Vec({9, 5});
  const EdgeReport thin =
      coarse.CheckEdge({.from = &a, .to = &b, .proof = EdgeProof::kCertificate});
  EXPECT_EQ(thin.state, EdgeState::kInvalid);
  EXPECT_FALSE(thin.certified);
}

// certify of a valid motion: kCertified without the samples the validity check already took.
// The same verdict and certificate on every edge the samples pass, for exactly the samples'
// collision checks less; and a motion that collides between its samples (a caller that
// skipped the validity check) is still found, by the certificate.
TEST(LocalPlannerTest, CertifyOfAValidMotionSkipsOnlyTheSamples) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.02});
  std::mt19937_64 rng(11);
  int compared = 0;
  for (int i = 0; i < 300; ++i) {
    const Config from = world->space().Sample(rng);
    Config to = world->space().Sample(rng);
    to.head<2>() = from.head<2>() + 0.15 * (to.head<2>() - from.head<2>());
    const EdgeReport sampled = Check(planner, from, to, false);
    if (sampled.state != EdgeState::kValid) continue;
    const EdgeReport certify =
        planner.CheckEdge({.from = &from, .to = &to, .proof = EdgeProof::kCertificate});
    const EdgeReport of_valid = planner.CheckEdge({.from = &from,
                                                   .to = &to,
                                                   .proof = EdgeProof::kCertificate,
                                                   .known = {.samples_valid = true}});
    ++compared;
    EXPECT_EQ(of_valid.state, certify.state) << "edge " << i;
    EXPECT_EQ(of_valid.certified, certify.certified) << "edge " << i;
    EXPECT_EQ(of_valid.has_clearance, certify.has_clearance) << "edge " << i;
    EXPECT_EQ(of_valid.distance_queries, certify.distance_queries) << "edge " << i;
    EXPECT_EQ(of_valid.collision_checks, certify.collision_checks - sampled.collision_checks)
        << "edge " << i;
  }
  EXPECT_GT(compared, 30);

  const LocalPlanner coarse(PointWorld({Box(3, 5, 0.05, 4)}), {.resolution = 0.5});
  const Config a = Vec({1, 5}), b = Vec({9, 5});
  ASSERT_EQ(Check(coarse, a, b, false).state, EdgeState::kValid);
  const EdgeReport thin = coarse.CheckEdge(
      {.from = &a, .to = &b, .proof = EdgeProof::kCertificate, .known = {.samples_valid = true}});
  EXPECT_EQ(thin.state, EdgeState::kInvalid);
  EXPECT_FALSE(thin.certified);
  EXPECT_EQ(thin.collision_checks, 0);
}

// Ends the caller knows valid skip their collision checks and nothing else: the same verdict,
// the same place of a collision inside the motion, two checks fewer.
TEST(LocalPlannerTest, EndsKnownValidSkipOnlyTheirChecks) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.02});
  auto context = world->MakeContext();
  std::mt19937_64 rng(13);
  int valid = 0, invalid_inside = 0;
  for (int i = 0; i < 300; ++i) {
    const Config from = world->space().Sample(rng);
    const Config to = world->space().Sample(rng);
    if (!context->Valid(from) || !context->Valid(to)) continue;
    for (const EdgeProof mode : {EdgeProof::kSamples, EdgeProof::kCertificate}) {
      const EdgeReport plain = planner.CheckEdge({.from = &from, .to = &to, .proof = mode});
      const EdgeReport known = planner.CheckEdge({.from = &from,
                                                  .to = &to,
                                                  .proof = mode,
                                                  .known = {.from_valid = true, .to_valid = true}});
      EXPECT_EQ(known.state, plain.state) << "edge " << i;
      EXPECT_EQ(known.invalid_at, plain.invalid_at) << "edge " << i;
      EXPECT_EQ(known.certified, plain.certified) << "edge " << i;
      EXPECT_EQ(known.collision_checks, plain.collision_checks - 2) << "edge " << i;
      EXPECT_EQ(known.distance_queries, plain.distance_queries) << "edge " << i;
      if (mode == EdgeProof::kSamples)
        (plain.state == EdgeState::kValid ? valid : invalid_inside)++;
    }
  }
  EXPECT_GT(valid, 10);
  EXPECT_GT(invalid_inside, 10);
}

// certify quick: kCertified's advancement without the profile where it stalls. It certifies
// only what certify certifies, finds the same collisions where it finds any, never costs more
// distance queries, and gives a grazing motion up after its first query where certify profiles it.
TEST(LocalPlannerTest, QuickCertifyGivesUpWhereAdvancementStalls) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.02});
  std::mt19937_64 rng(6);
  int certified = 0, invalid = 0;
  for (int i = 0; i < 300; ++i) {
    const Config from = world->space().Sample(rng);
    Config to = world->space().Sample(rng);
    to.head<2>() = from.head<2>() + 0.15 * (to.head<2>() - from.head<2>());
    const EdgeReport full =
        planner.CheckEdge({.from = &from, .to = &to, .proof = EdgeProof::kCertificate});
    const EdgeReport quick =
        planner.CheckEdge({.from = &from, .to = &to, .proof = EdgeProof::kCertificateOrGiveUp});
    EXPECT_LE(quick.distance_queries, full.distance_queries) << "edge " << i;
    EXPECT_FALSE(quick.has_clearance) << "edge " << i;
    if (quick.state == EdgeState::kInvalid) {
      ++invalid;
      EXPECT_EQ(full.state, EdgeState::kInvalid) << "edge " << i;
      EXPECT_EQ(full.invalid_at, quick.invalid_at) << "edge " << i;
    } else if (quick.certified) {
      ++certified;
      EXPECT_TRUE(full.certified) << "edge " << i;
      EXPECT_EQ(full.distance_queries, quick.distance_queries) << "edge " << i;
    }
  }
  EXPECT_GT(certified, 30);
  EXPECT_GT(invalid, 10);

  // A motion along a box's top face, 1e-7 above it: the advancement stalls at once. Certify
  // profiles it (and cannot certify it either); quick gives up after the first query.
  const LocalPlanner planner_box(PointWorld({Box(5, 5, 2, 2)}), {.resolution = 0.01});
  const Config a = Vec({4.5, 6 + 1e-7}), b = Vec({5.5, 6 + 1e-7});
  const EdgeReport full =
      planner_box.CheckEdge({.from = &a, .to = &b, .proof = EdgeProof::kCertificate});
  const EdgeReport quick =
      planner_box.CheckEdge({.from = &a, .to = &b, .proof = EdgeProof::kCertificateOrGiveUp});
  EXPECT_EQ(full.state, EdgeState::kValid);
  EXPECT_FALSE(full.certified);
  EXPECT_EQ(quick.state, EdgeState::kValid);
  EXPECT_FALSE(quick.certified);
  EXPECT_EQ(quick.distance_queries, 1);
  EXPECT_GT(full.distance_queries, 8);
  std::printf("[ box face ] distance queries: certify %lld, quick %lld\n",
              static_cast<long long>(full.distance_queries),
              static_cast<long long>(quick.distance_queries));
}

// Probes are samples of the profile: same t, same clearance. Bounds built on them hold for the
// profile's values (inverse clearance below, bottleneck above) and tighten as probes are added.
TEST(LocalPlannerTest, ProbesAreProfileSamplesAndTightenTheBounds) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.01});
  const auto inverse = Measure::Make({.type = MeasureType::kInverseClearance, .k = 3});
  const auto bottleneck = Measure::Make({.type = MeasureType::kBottleneckClearance});
  int tightened = 0, floored = 0, reached = 0;
  const auto visit = [&](int i, const Config& from, const Config& to, const EdgeReport& profile) {
    EdgeBoundInput input{.length = profile.length,
                         .clearance_from = planner.Clearance(from),
                         .clearance_to = planner.Clearance(to),
                         .motion_bound = planner.MotionBound(from, to)};
    // What either end proves of the clearance at a point (the scan skips the points it proves
    // free) lies under the profile there.
    for (const ClearanceSample& sample : profile.profile) {
      const double reach = std::max(
          ReachFloor({.t = 0, .clearance = input.clearance_from}, sample.t, input.motion_bound),
          ReachFloor({.t = 1, .clearance = input.clearance_to}, sample.t, input.motion_bound));
      EXPECT_LE(reach, sample.clearance) << "edge " << i << " t " << sample.t;
      reached += reach > 0;
    }
    double previous = inverse->EdgeBound(input);
    std::vector<ClearanceSample> probes;
    for (const std::vector<double>& fractions :
         {std::vector<double>{0.5}, {0.25, 0.75}, {0.125, 0.375, 0.625, 0.875}}) {
      const int64_t before = planner.total_distance_queries();
      const std::vector<ClearanceSample> found =
          planner.ProbeClearance(from, to, fractions, probes, ProbeOrder::kDistanceOnly);
      EXPECT_EQ(planner.total_distance_queries() - before, static_cast<int64_t>(found.size()));
      for (const ClearanceSample& sample : found) {
        const auto in_profile =
            std::find_if(profile.profile.begin(), profile.profile.end(),
                         [&](const ClearanceSample& p) { return p.t == sample.t; });
        ASSERT_NE(in_profile, profile.profile.end()) << "edge " << i << " t " << sample.t;
        EXPECT_EQ(in_profile->clearance, sample.clearance);
        EXPECT_GT(sample.t, 0);
        EXPECT_LT(sample.t, 1);
        probes.push_back(sample);
      }
      std::sort(probes.begin(), probes.end(),
                [](const ClearanceSample& a, const ClearanceSample& b) { return a.t < b.t; });
      // Nothing twice: the same points asked for again are not probed again.
      const int64_t again = planner.total_distance_queries();
      EXPECT_TRUE(
          planner.ProbeClearance(from, to, fractions, probes, ProbeOrder::kDistanceOnly).empty());
      EXPECT_EQ(planner.total_distance_queries(), again);
      input.interior = &probes;
      const double bound = inverse->EdgeBound(input);
      EXPECT_LE(bound, inverse->EdgeValue(profile)) << "edge " << i;
      EXPECT_GE(bound, previous * (1 - 1e-12)) << "edge " << i;
      if (bound > previous * 1.01) ++tightened;
      previous = bound;
      EXPECT_GE(bottleneck->EdgeBound(input), bottleneck->EdgeValue(profile)) << "edge " << i;
      // The floor lies under every sample of the profile, refinements included.
      const double floor = ClearanceFloor(input);
      EXPECT_LE(floor, MinClearance(profile)) << "edge " << i;
      if (floor > 0) {
        ++floored;
        EXPECT_LE(bottleneck->EdgeFloor(input), bottleneck->EdgeValue(profile)) << "edge " << i;
      }
    }
  };
  const int compared = ForShortFreeMotions(planner, 11, visit);
  EXPECT_GE(compared, 30);
  EXPECT_GT(tightened, compared / 2);
  EXPECT_GT(floored, compared / 2);
  EXPECT_GT(reached, 2 * compared);
}

// The witnesses of an edge's ends and probes bound its clearance from above at every grid point
// (the ceilings lazy evaluation takes): each ceiling lies over the profile's sample there, the
// inverse clearance bound they give still lies under the edge's cost, and they tighten it on
// most edges.
TEST(LocalPlannerTest, WitnessCeilingsLieOverTheProfileAndTightenTheBounds) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.01});
  const auto inverse = Measure::Make({.type = MeasureType::kInverseClearance, .k = 3});
  int tightened = 0, ceilings = 0;
  const auto visit = [&](int i, const Config& from, const Config& to, const EdgeReport& profile) {
    std::vector<ClearanceWitness> witnesses(2);
    const int64_t before = planner.total_distance_queries();
    EdgeBoundInput input{.length = profile.length,
                         .clearance_from = planner.ClearanceAndWitness(from, &witnesses[0]),
                         .clearance_to = planner.ClearanceAndWitness(to, &witnesses[1]),
                         .motion_bound = planner.MotionBound(from, to)};
    EXPECT_EQ(planner.total_distance_queries() - before, 2);
    EXPECT_EQ(input.clearance_from, profile.profile.front().clearance);
    const std::vector<ClearanceSample> probes = planner.ProbeClearance(
        from, to, {0.25, 0.5, 0.75}, {}, ProbeOrder::kDistanceOnly, &witnesses);
    EXPECT_EQ(witnesses.size(), 2 + probes.size());
    input.interior = &probes;
    const double without = inverse->EdgeBound(input);
    // A ceiling at every interior grid point.
    const int stretches = planner.ProfileStretches(profile.length);
    std::vector<ClearanceSample> ceiling;
    for (int k = 1; k < stretches; ++k) {
      ceiling.push_back({.t = static_cast<double>(k) / stretches,
                         .clearance = std::numeric_limits<double>::infinity()});
    }
    planner.LowerToWitnesses(from, to, witnesses, &ceiling);
    for (const ClearanceSample& c : ceiling) {
      const auto in_profile = std::find_if(profile.profile.begin(), profile.profile.end(),
                                           [&](const ClearanceSample& p) { return p.t == c.t; });
      ASSERT_NE(in_profile, profile.profile.end()) << "edge " << i << " t " << c.t;
      EXPECT_GE(c.clearance, in_profile->clearance) << "edge " << i << " t " << c.t;
      ceilings += std::isfinite(c.clearance);
    }
    input.ceiling = &ceiling;
    const double with = inverse->EdgeBound(input);
    EXPECT_LE(with, inverse->EdgeValue(profile)) << "edge " << i;
    EXPECT_GE(with, without * (1 - 1e-12)) << "edge " << i;
    tightened += with > without * 1.01;
  };
  const int compared = ForShortFreeMotions(planner, 12, visit);
  EXPECT_GE(compared, 30);
  EXPECT_GT(ceilings, 3 * compared);
  EXPECT_GT(tightened, compared / 2);
}

// Collision first: the same samples up to the first point in contact, which it reports with
// clearance 0 for a collision check instead of a distance query, and nothing after it.
TEST(LocalPlannerTest, CollisionFirstProbesStopAtContactForLessDistanceQueries) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.01});
  const Space& space = world->space();
  const std::vector<double> fractions = {0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875};
  std::mt19937_64 rng(13);
  int in_contact = 0, free = 0;
  int64_t saved = 0;
  for (int i = 0; i < 200; ++i) {
    const Config from = space.Sample(rng);
    const Config to = space.Sample(rng);
    const int64_t queries = planner.total_distance_queries();
    const int64_t checks = planner.total_collision_checks();
    const std::vector<ClearanceSample> plain =
        planner.ProbeClearance(from, to, fractions, {}, ProbeOrder::kDistanceOnly);
    const int64_t plain_queries = planner.total_distance_queries() - queries;
    EXPECT_EQ(planner.total_collision_checks(), checks);
    const int64_t queries_first = planner.total_distance_queries();
    const int64_t checks_first = planner.total_collision_checks();
    const std::vector<ClearanceSample> first =
        planner.ProbeClearance(from, to, fractions, {}, ProbeOrder::kCollisionFirst);
    const int64_t first_queries = planner.total_distance_queries() - queries_first;
    EXPECT_EQ(planner.total_collision_checks() - checks_first, static_cast<int64_t>(first.size()));
    const auto contact = std::find_if(plain.begin(), plain.end(),
                                      [](const ClearanceSample& p) { return p.clearance <= 0; });
    if (contact == plain.end()) {
      ++free;
      ASSERT_EQ(first.size(), plain.size()) << "edge " << i;
      EXPECT_EQ(first_queries, plain_queries);
    } else {
      ++in_contact;
      ASSERT_EQ(first.size(), static_cast<size_t>(contact - plain.begin()) + 1) << "edge " << i;
      EXPECT_EQ(first.back().t, contact->t);
      EXPECT_EQ(first.back().clearance, 0);
      EXPECT_LT(first_queries, plain_queries);
      saved += plain_queries - first_queries;
    }
    for (size_t j = 0; j + 1 < first.size(); ++j) {
      EXPECT_EQ(first[j].t, plain[j].t);
      EXPECT_EQ(first[j].clearance, plain[j].clearance);
    }
  }
  EXPECT_GT(in_contact, 20);
  EXPECT_GT(free, 5);
  EXPECT_GT(saved, in_contact);
}

// A scan for contact: collision checks only, in the order given (the middle first here), up to
// the first point in contact, which is one the distance probes also find in contact; nothing for
// an edge free at every point.
TEST(LocalPlannerTest, CollisionOnlyScanFindsContactInTheGivenOrderWithoutDistanceQueries) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.01});
  const Space& space = world->space();
  const std::vector<double> fractions = {0.5, 0.25, 0.75, 0.125, 0.375, 0.625, 0.875};
  std::mt19937_64 rng(17);
  int in_contact = 0, free = 0;
  for (int i = 0; i < 200; ++i) {
    const Config from = space.Sample(rng);
    const Config to = space.Sample(rng);
    const int64_t queries = planner.total_distance_queries();
    const int64_t checks = planner.total_collision_checks();
    const std::vector<ClearanceSample> scan =
        planner.ProbeClearance(from, to, fractions, {}, ProbeOrder::kCollisionOnly);
    EXPECT_EQ(planner.total_distance_queries(), queries);
    const int64_t scan_checks = planner.total_collision_checks() - checks;
    const std::vector<ClearanceSample> plain =
        planner.ProbeClearance(from, to, fractions, {}, ProbeOrder::kDistanceOnly);
    const auto touching = [&](double t) {
      return std::any_of(plain.begin(), plain.end(),
                         [t](const ClearanceSample& p) { return p.t == t && p.clearance <= 0; });
    };
    if (scan.empty()) {
      ++free;
      EXPECT_EQ(scan_checks, static_cast<int64_t>(plain.size()));
      for (const ClearanceSample& p : plain) EXPECT_GT(p.clearance, 0) << "edge " << i;
      continue;
    }
    ++in_contact;
    ASSERT_EQ(scan.size(), 1u);
    EXPECT_EQ(scan.front().clearance, 0);
    EXPECT_TRUE(touching(scan.front().t)) << "edge " << i;
    // The points before it in the given order are free.
    const int segments = planner.ProfileStretches(space.Distance(from, to));
    int before = 0;
    std::vector<double> seen;
    for (double f : fractions) {
      const double t = static_cast<double>(std::lround(f * segments)) / segments;
      if (std::find(seen.begin(), seen.end(), t) != seen.end()) continue;  // checked once
      seen.push_back(t);
      const auto at = std::find_if(plain.begin(), plain.end(),
                                   [&](const ClearanceSample& p) { return p.t == t; });
      if (at == plain.end()) continue;
      if (at->t == scan.front().t) break;
      EXPECT_GT(at->clearance, 0) << "edge " << i;
      ++before;
    }
    EXPECT_EQ(scan_checks, before + 1) << "edge " << i;
  }
  EXPECT_GT(in_contact, 20);
  EXPECT_GT(free, 5);
}

// A profile that is handed clearances known on its grid (the probes, an end's) records the same
// samples and verdict as one that queries them all, for fewer distance queries.
TEST(LocalPlannerTest, ProfileWithKnownGridClearancesEqualsTheFullProfile) {
  const auto world = CircleWorld();
  const LocalPlanner planner(world, {.resolution = 0.01});
  const Space& space = world->space();
  std::mt19937_64 rng(13);
  int compared = 0, invalid = 0;
  for (int i = 0; i < 200; ++i) {
    const Config from = space.Sample(rng);
    Config to = space.Sample(rng);
    to.head<2>() = from.head<2>() + 0.2 * (to.head<2>() - from.head<2>());
    const EdgeReport full = Check(planner, from, to, true);
    const int stretches = planner.ProfileStretches(full.length);
    ASSERT_EQ(stretches + 1, planner.SampleCount(full.length));
    std::vector<double> fractions;
    for (int k = 1; k < stretches; ++k) fractions.push_back(static_cast<double>(k) / stretches);
    std::vector<ClearanceSample> known =
        planner.ProbeClearance(from, to, fractions, {}, ProbeOrder::kDistanceOnly);
    ASSERT_EQ(static_cast<int>(known.size()), std::max(0, stretches - 1));
    known.insert(known.begin(), {0.0, planner.Clearance(from)});
    const EdgeReport reused = planner.CheckEdge(
        {.from = &from, .to = &to, .proof = EdgeProof::kProfile, .known = {.clearances = &known}});
    ASSERT_EQ(reused.state, full.state) << "edge " << i;
    if (full.state != EdgeState::kValid) {
      ++invalid;
      continue;
    }
    ++compared;
    EXPECT_EQ(reused.certified, full.certified);
    ASSERT_EQ(reused.profile.size(), full.profile.size()) << "edge " << i;
    for (size_t k = 0; k < full.profile.size(); ++k) {
      EXPECT_EQ(reused.profile[k].t, full.profile[k].t);
      EXPECT_EQ(reused.profile[k].clearance, full.profile[k].clearance);
    }
    // Only the far end and the refinements are queried.
    EXPECT_EQ(reused.distance_queries, full.distance_queries - static_cast<int64_t>(known.size()));
  }
  EXPECT_GE(compared, 30);
  EXPECT_GE(invalid, 5);
}

TEST(LocalPlannerTest, CountersAddUp) {
  const LocalPlanner planner(PointWorld({Box(5, 5, 2, 2)}));
  const Config a = Vec({1, 1}), b = Vec({9, 1}), c = Vec({5, 5});
  int64_t checks = 0, queries = 0;
  for (const auto& [from, to] : {std::pair{a, b}, std::pair{a, c}, std::pair{b, a}}) {
    const EdgeReport report = Check(planner, from, to, true);
    checks += report.collision_checks;
    queries += report.distance_queries;
  }
  EXPECT_TRUE(planner.IsValid(a));
  EXPECT_GT(planner.Clearance(a), 0.0);
  EXPECT_EQ(planner.total_collision_checks(), checks + 1);
  EXPECT_EQ(planner.total_distance_queries(), queries + 1);
}

void ExpectSameReport(const EdgeReport& a, const EdgeReport& b, int edge) {
  EXPECT_EQ(a.state, b.state) << edge;
  EXPECT_EQ(a.invalid_at, b.invalid_at) << edge;
  EXPECT_EQ(a.certified, b.certified) << edge;
  EXPECT_EQ(a.has_clearance, b.has_clearance) << edge;
  EXPECT_EQ(a.collision_checks, b.collision_checks) << edge;
  EXPECT_EQ(a.distance_queries, b.distance_queries) << edge;
  ASSERT_EQ(a.profile.size(), b.profile.size()) << edge;
  for (size_t k = 0; k < a.profile.size(); ++k) {
    EXPECT_EQ(a.profile[k].t, b.profile[k].t) << edge;
    EXPECT_EQ(a.profile[k].clearance, b.profile[k].clearance) << edge;
  }
}

TEST(LocalPlannerThreadTest, ParallelChecksAgreeWithSerial) {
  const auto world = CircleWorld();
  std::mt19937_64 rng(17);
  std::vector<std::pair<Config, Config>> edges;
  for (int i = 0; i < 400; ++i) {
    const Config from = world->space().Sample(rng);
    Config to = world->space().Sample(rng);
    to.head<2>() = from.head<2>() + 0.2 * (to.head<2>() - from.head<2>());
    edges.emplace_back(from, to);
  }
  std::vector<EdgeReport> serial;
  {
    const LocalPlanner planner(world, {.resolution = 0.01});
    for (size_t i = 0; i < edges.size(); ++i) {
      serial.push_back(Check(planner, edges[i].first, edges[i].second, i % 2 == 0));
    }
  }
  const LocalPlanner planner(world, {.resolution = 0.01});
  std::vector<EdgeReport> parallel(edges.size());
  const auto work = [&](size_t first) {
    for (size_t i = first; i < edges.size(); i += 2) {
      parallel[i] = Check(planner, edges[i].first, edges[i].second, i % 2 == 0);
    }
  };
  std::thread t0(work, 0), t1(work, 1);
  t0.join();
  t1.join();
  int64_t checks = 0, queries = 0;
  for (size_t i = 0; i < edges.size(); ++i) {
    ExpectSameReport(parallel[i], serial[i], static_cast<int>(i));
    checks += serial[i].collision_checks;
    queries += serial[i].distance_queries;
  }
  EXPECT_EQ(planner.total_collision_checks(), checks);
  EXPECT_EQ(planner.total_distance_queries(), queries);
}

}  // namespace
}  // namespace hgraph
