// Direction-aware conservative advancement (CollisionContext::FreeFraction,
// LocalPlannerOptions::direction_bound) with real FCL on real meshes: what it calls free is free
// (exact clearances along the motion), it never stops short of the bound by how far any point
// moves, it lets a motion slide along a wall, and what the local planner certifies with it has an
// exact certified profile.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/merge/merge.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"
#include "core/path/path.h"
#include "tests/unit/mesh_problems.h"

namespace hgraph {
namespace {

using testing::BoxMesh;
using testing::LoadWorld;
using testing::MeshProblem;
using testing::MeshProblems;

const std::string kRoot = HGRAPH_SOURCE_DIR;

Config Se3(double x, double y, double z, double yaw = 0) {
  const Eigen::Quaterniond r(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  Config q(7);
  q << x, y, z, r.x(), r.y(), r.z(), r.w();
  return q;
}

// A unit cube robot beside a wall 20 long and 0.2 thick in the plane y = 0.
std::shared_ptr<const CollisionWorld> WallWorld() {
  auto scene = std::make_shared<Scene>(Scene{
      .space = Space::SE3(Eigen::Vector3d::Constant(-10), Eigen::Vector3d::Constant(10)),
  });
  scene->obstacles.push_back(Obstacle{
      .name = "wall",
      .shape = Shape{.type = ShapeType::kMesh, .mesh = BoxMesh({20, 0.2, 20}), .source = "test"}});
  scene->robot.push_back(RobotBody{
      .name = "cube",
      .shape = Shape{.type = ShapeType::kMesh, .mesh = BoxMesh({1, 1, 1}), .source = "test"}});
  return std::make_shared<const CollisionWorld>(scene);
}

// Space::Motion describes Interpolate: the frame at t is the frame at a moved by t * translation
// and turned by t * angle about the axis.
TEST(FreeMotionTest, FrameMotionDescribesInterpolation) {
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    const Space& space = world->space();
    std::mt19937_64 rng(3);
    for (int i = 0; i < 200; ++i) {
      const Config a = space.Sample(rng);
      const Config b = space.Interpolate(a, space.Sample(rng), i % 2 ? 0.05 : 1.0);
      const double t = std::uniform_real_distribution<double>(0, 1)(rng);
      const Config q = space.Interpolate(a, b, t);
      for (int c = 0; c < space.num_components(); ++c) {
        if (!space.CanDriveBody(c)) continue;
        const Space::FrameMotion motion = space.Motion(c, a, b);
        EXPECT_NEAR(motion.angle, space.RotationAngle(c, a, b), 1e-9);
        EXPECT_NEAR(motion.axis.norm(), 1.0, 1e-12);
        Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
        moved.translation() = t * motion.translation;
        moved.linear() = Eigen::AngleAxisd(t * motion.angle, motion.axis).toRotationMatrix();
        const Eigen::Isometry3d want = space.Pose(c, a) * moved;
        const Eigen::Isometry3d got = space.Pose(c, q);
        EXPECT_LT((want.linear() - got.linear()).norm(), 1e-9) << "motion " << i;
        EXPECT_LT((want.translation() - got.translation()).norm(),
                  1e-9 * (1 + got.translation().norm()))
            << "motion " << i;
      }
    }
  }
}

// What FreeFraction calls free is free: exact clearance above 0 all along [0, s), sampled evenly
// and ever closer to s; and s is never below the bound by how far any point moves,
// clearance / MotionBound (one-sided advancement from the start).
TEST(FreeMotionTest, WhatItCallsFreeIsFree) {
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    if (!world->CanAdvance()) {
      EXPECT_FALSE(world->SelfPairs().empty());
      continue;
    }
    const Space& space = world->space();
    const LocalPlanner planner(world, {.direction_bound = false});
    auto context = world->MakeContext();
    auto exact = world->MakeContext();
    std::mt19937_64 rng(5);
    int motions = 0;
    int past_classic = 0;  // motions where s is over twice the classic bound
    int whole = 0;
    std::vector<double> gains;
    while (motions < 60) {
      const Config q = space.Sample(rng);
      const double clearance = exact->Clearance(q);
      if (clearance <= 0) continue;
      const Config to = space.Interpolate(q, space.Sample(rng), motions % 3 == 0 ? 1.0 : 0.05);
      const double s = context->FreeFraction(q, to, 1.0);
      ASSERT_GT(s, 0) << "motion " << motions;
      ASSERT_LE(s, 1.0);
      const double classic = std::min(1.0, clearance / planner.MotionBound(q, to));
      EXPECT_GE(s, 0.99 * classic) << "motion " << motions;
      std::vector<double> ts;
      for (int k = 0; k < 100; ++k) ts.push_back(s * k / 100.0);
      for (int j = 1; j <= 8; ++j) ts.push_back(s * (1 - std::pow(10.0, -j)));
      for (double t : ts) {
        ASSERT_GT(exact->Clearance(space.Interpolate(q, to, t)), 0)
            << "motion " << motions << " at " << t << " of " << s;
      }
      past_classic += s > 2 * classic;
      whole += s == 1.0;
      gains.push_back(s / classic);
      ++motions;
    }
    EXPECT_EQ(context->distance_queries(), motions);
    std::sort(gains.begin(), gains.end());
    std::printf(
        "%s: %d of %d motions free over twice the classic bound, %d whole; median gain %.2f\n",
        p.name.c_str(), past_classic, motions, whole, gains[gains.size() / 2]);
  }
}

// In contact at the start: 0. Out of bounds: 0.
TEST(FreeMotionTest, ContactAtTheStartIsZero) {
  const auto world = WallWorld();
  auto context = world->MakeContext();
  EXPECT_EQ(context->FreeFraction(Se3(0, 0.3, 0), Se3(5, 5, 0), 1.0), 0.0);
  EXPECT_EQ(context->FreeFraction(Se3(0, 5, 11), Se3(0, 5, 0), 1.0), 0.0);
  EXPECT_EQ(context->distance_queries(), 2);
}

// A cube sliding along a wall 0.05 away is free for a long way from each query, where the bound
// by how far any point moves allows 0.5 % of it; moving into the wall stops where its face meets
// the wall, and turning on the spot beside it is free for part of the way the corners stay clear.
TEST(FreeMotionTest, SlidingAlongAWallIsFree) {
  const auto world = WallWorld();
  auto context = world->MakeContext();
  const LocalPlanner planner(world, {.direction_bound = false});
  const Config start = Se3(-5, 0.65, 0);
  const Config along = Se3(5, 0.65, 0);
  const double classic = planner.Clearance(start) / planner.MotionBound(start, along);
  EXPECT_LT(classic, 0.01);
  EXPECT_GT(context->FreeFraction(start, along, 1.0), 20 * classic);
  // The face at y - 0.5 meets the wall's at 0.1: y = 0.6, a fraction 0.05 / 4 of the way.
  const double into = context->FreeFraction(start, Se3(-5, -3.35, 0), 1.0);
  EXPECT_LE(into, 0.0125 + 1e-12);
  EXPECT_GE(into, 0.0125 * (1 - 1e-6));
  // Turned by phi about z, the corner nearest the wall comes within 0.65 - (cos phi + sin phi) / 2
  // of its axis; it reaches y = 0.1 when sin(phi + pi / 4) = 0.55 / (0.5 sqrt 2).
  const double phi = std::asin(0.55 / (0.5 * std::sqrt(2.0))) - M_PI / 4;
  const double turn = context->FreeFraction(start, Se3(-5, 0.65, 0, 1.0), 1.0);
  EXPECT_LE(turn, phi + 1e-9);
  EXPECT_GT(turn, 0.5 * phi);

  // The local planner certifies the slide in a few queries with the direction bound, where
  // two-sided advancement on clearances needs a hundred.
  const LocalPlanner direction(world);
  const EdgeCheckRequest request{.from = &start, .to = &along, .proof = EdgeProof::kCertificate};
  const EdgeReport with = direction.CheckEdge(request);
  const EdgeReport without = planner.CheckEdge(request);
  EXPECT_TRUE(with.certified);
  EXPECT_TRUE(without.certified);
  EXPECT_LE(with.distance_queries, 5);
  EXPECT_GT(without.distance_queries, 50);
}

// What the local planner certifies with the direction bound (with a profile or without) is free
// at 100 points along it and has a valid exact profile, and a motion it finds in collision
// collides; it certifies at least what advancement on clearances does, with fewer queries.
TEST(FreeMotionTest, DirectionCertificatesAreExactCertificates) {
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    const LocalPlanner classic(world, {.direction_bound = false});
    const LocalPlanner direction(world);
    std::mt19937_64 rng(11);
    std::vector<Config> free;
    while (free.size() < 60) {
      const Config q = world->space().Sample(rng);
      if (classic.Clearance(q) > 0) free.push_back(q);
    }
    int certified = 0;
    int certified_classic = 0;
    int64_t queries = 0;
    int64_t queries_classic = 0;
    for (size_t i = 0; i + 1 < free.size(); ++i) {
      const Config to = world->space().Interpolate(free[i], free[i + 1], i % 2 ? 0.1 : 1.0);
      for (const EdgeProof mode :
           {EdgeProof::kCertificate, EdgeProof::kCertificateOrGiveUp, EdgeProof::kProfile}) {
        const EdgeCheckRequest request{.from = &free[i], .to = &to, .proof = mode};
        const EdgeReport with = direction.CheckEdge(request);
        const EdgeReport without = classic.CheckEdge(request);
        const EdgeReport profile =
            classic.CheckEdge({.from = &free[i], .to = &to, .proof = EdgeProof::kProfile});
        if (with.state == EdgeState::kInvalid) {
          EXPECT_EQ(profile.state, EdgeState::kInvalid) << "motion " << i;
        }
        if (with.certified) {
          ++certified;
          EXPECT_EQ(with.state, EdgeState::kValid);
          EXPECT_EQ(profile.state, EdgeState::kValid) << "motion " << i;
          for (int k = 0; k <= 100; ++k) {
            ASSERT_GT(classic.Clearance(world->space().Interpolate(free[i], to, k / 100.0)), 0)
                << "motion " << i << " at " << k / 100.0;
          }
        }
        if (without.certified) {
          EXPECT_TRUE(with.certified) << "motion " << i;
        }
        certified_classic += without.certified;
        queries += with.distance_queries;
        queries_classic += without.distance_queries;
      }
    }
    EXPECT_GT(certified, 5);
    EXPECT_GE(certified, certified_classic * 9 / 10);
    std::printf(
        "%s: %d certified with the direction bound (%lld queries), %d on clearances (%lld)\n",
        p.name.c_str(), certified, static_cast<long long>(queries), certified_classic,
        static_cast<long long>(queries_classic));
  }
}

// Certificates from both ends (LocalPlannerOptions::advance_from_both_ends), on random motions
// and on motions that start next to an obstacle (as a shortened path's corners do): the verdict
// is the same either way along a motion, as from the start alone it need not be; what the start
// alone certifies is certified; what is certified is free at 100 points; and sharing the check
// with a second thread (EdgeCheckRequest::threads) changes no verdict.
TEST(FreeMotionTest, CertificatesFromBothEndsDoNotDependOnTheDirection) {
  int asymmetric_one_end = 0;
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    if (!world->CanAdvance()) continue;
    const Space& space = world->space();
    const LocalPlanner exact(world, {.direction_bound = false});
    const LocalPlanner one_end(world, {.advance_from_both_ends = false});
    const LocalPlanner both_ends(world);
    std::mt19937_64 rng(17);
    int motions = 0;
    int certified = 0;
    int certified_one = 0;
    while (motions < 60) {
      const Config free = space.Sample(rng);
      const Config other = space.Sample(rng);
      if (exact.Clearance(free) <= 0) continue;
      Config start = free;
      if (motions % 2 == 1) {
        // Pushed towards the other point until it nearly touches what lies between.
        if (exact.Clearance(other) > 0) continue;
        double lo = 0;
        double hi = 1;
        for (int k = 0; k < 20; ++k) {
          const double mid = 0.5 * (lo + hi);
          (exact.Clearance(space.Interpolate(free, other, mid)) > 0 ? lo : hi) = mid;
        }
        start = space.Interpolate(free, other, lo);
      }
      const Config to = space.Interpolate(start, space.Sample(rng), motions % 3 == 0 ? 1.0 : 0.1);
      if (exact.Clearance(to) <= 0) continue;
      ++motions;
      const auto check = [&](const LocalPlanner& planner, const Config& a, const Config& b,
                             int threads) {
        return planner.CheckEdge(
            {.from = &a, .to = &b, .proof = EdgeProof::kCertificateOrGiveUp, .threads = threads});
      };
      const EdgeReport one = check(one_end, start, to, 1);
      const EdgeReport one_back = check(one_end, to, start, 1);
      const EdgeReport both = check(both_ends, start, to, 1);
      const EdgeReport both_back = check(both_ends, to, start, 1);
      const EdgeReport beside = check(both_ends, start, to, 2);
      ASSERT_EQ(one.state, both.state) << "motion " << motions;
      ASSERT_EQ(both.state, beside.state) << "motion " << motions;
      EXPECT_EQ(both.certified, both_back.certified) << "motion " << motions;
      EXPECT_EQ(both.certified, beside.certified) << "motion " << motions;
      if (one.certified || one_back.certified) {
        EXPECT_TRUE(both.certified) << "motion " << motions;
      }
      asymmetric_one_end += one.certified != one_back.certified;
      certified += both.certified;
      certified_one += one.certified;
      if (!both.certified) continue;
      for (int k = 0; k <= 100; ++k) {
        ASSERT_GT(exact.Clearance(space.Interpolate(start, to, k / 100.0)), 0)
            << "motion " << motions << " at " << k / 100.0;
      }
    }
    EXPECT_GT(certified, 5);
    std::printf("%s: of %d motions, %d certified from both ends, %d from the start alone\n",
                p.name.c_str(), motions, certified, certified_one);
  }
  std::printf("%d motions certified from one end and not from the other\n", asymmetric_one_end);
}

// A certificate whose first front stalls because the motion runs into an obstacle between its
// samples is answered by collision checks just past the stall: the motion is reported invalid at
// a state that collides, the same with a second thread, and the second front is not run.
TEST(FreeMotionTest, AStallIntoAnObstacleIsFoundInCollision) {
  int found = 0;
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    if (!world->CanAdvance()) continue;
    const Space& space = world->space();
    // Samples five times sparser than the default, so that more motions collide between them.
    const LocalPlanner planner(world, {.resolution = 0.05});
    std::mt19937_64 rng(29);
    for (int i = 0; i < 600; ++i) {
      // From a free state pushed towards a state in collision until it nearly touches what lies
      // between, a short way on.
      const Config free = space.Sample(rng);
      const Config other = space.Sample(rng);
      if (!planner.IsValid(free) || planner.IsValid(other)) continue;
      double lo = 0;
      double hi = 1;
      for (int k = 0; k < 20; ++k) {
        const double mid = 0.5 * (lo + hi);
        (planner.IsValid(space.Interpolate(free, other, mid)) ? lo : hi) = mid;
      }
      const Config a = space.Interpolate(free, other, lo);
      const Config b = space.Interpolate(a, space.Sample(rng), 0.1);
      EdgeCheckRequest request{.from = &a, .to = &b, .proof = EdgeProof::kSamples};
      if (planner.CheckEdge(request).state != EdgeState::kValid) continue;
      request.proof = EdgeProof::kCertificateOrGiveUp;
      const EdgeReport alone = planner.CheckEdge(request);
      request.threads = 2;
      const EdgeReport shared = planner.CheckEdge(request);
      ASSERT_EQ(alone.state, shared.state) << "motion " << i;
      ASSERT_EQ(alone.certified, shared.certified) << "motion " << i;
      if (alone.state != EdgeState::kInvalid) continue;
      EXPECT_EQ(alone.invalid_at, shared.invalid_at) << "motion " << i;
      ASSERT_GT(alone.invalid_at, 0) << "motion " << i;
      ASSERT_LT(alone.invalid_at, 1) << "motion " << i;
      EXPECT_FALSE(planner.IsValid(space.Interpolate(a, b, alone.invalid_at))) << "motion " << i;
      ++found;
    }
  }
  // Motions valid at every sample and found in collision between two of them.
  EXPECT_GT(found, 8);
  std::printf("%d motions valid at their samples found in collision past a stalled front\n", found);
}

// Sharing the samples of a motion with a second thread finds the same first sample in collision.
TEST(FreeMotionTest, SharedSamplesFindTheSameFirstCollision) {
  const MeshProblem p = MeshProblems()[3];
  const auto world = LoadWorld(p);
  const LocalPlanner planner(world);
  std::mt19937_64 rng(23);
  int invalid = 0;
  for (int i = 0; i < 200; ++i) {
    const Config a = world->space().Sample(rng);
    const Config b = world->space().Sample(rng);
    EdgeCheckRequest request{.from = &a, .to = &b, .proof = EdgeProof::kSamples};
    const EdgeReport alone = planner.CheckEdge(request);
    request.threads = 2;
    const EdgeReport shared = planner.CheckEdge(request);
    ASSERT_EQ(alone.state, shared.state) << "motion " << i;
    EXPECT_EQ(alone.invalid_at, shared.invalid_at) << "motion " << i;
    invalid += alone.state == EdgeState::kInvalid && alone.invalid_at > 0 && alone.invalid_at < 1;
  }
  EXPECT_GT(invalid, 5);
}

// A default merge of the bench's fixed home inputs with the direction bound: its path passes
// CheckPaths on the exact checker, certified, keeps the endpoints and is no longer than the
// best input.
TEST(FreeMotionTest, MergedPathsWithTheDirectionBoundAreCertifiedExactly) {
  const MeshProblem p = MeshProblems()[3];
  const auto world = LoadWorld(p);
  const LocalPlanner exact(world, {.direction_bound = false});
  const LocalPlanner direction(world);
  const std::vector<InputPath> inputs =
      LoadPathsFile(kRoot + "/tests/bench/results/real/inputs/home.json", world->space());
  const MergeResult merged = Merge(direction, MergeRequest{.paths = inputs});
  const PathCheckResult check = CheckPaths(exact, PathCheckRequest{.paths = {merged.path}});
  ASSERT_EQ(check.paths.size(), 1u);
  EXPECT_TRUE(check.paths[0].valid) << check.paths[0].invalid_reason;
  EXPECT_TRUE(check.paths[0].certified);
  EXPECT_EQ(merged.path.waypoints.front(), inputs[0].waypoints.front());
  EXPECT_EQ(merged.path.waypoints.back(), inputs[0].waypoints.back());
  double best_input = std::numeric_limits<double>::infinity();
  for (const InputPath& input : inputs) {
    best_input = std::min(best_input, PathLength(world->space(), input));
  }
  EXPECT_LE(merged.quality.length, best_input);
}

}  // namespace
}  // namespace hgraph
