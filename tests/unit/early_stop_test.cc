// FCL's early-stopped distance as a certified lower bound on clearance
// (CollisionContext::ClearanceLowerBound, LocalPlannerOptions::certificate_rel_err), on the mesh
// scenes with real FCL: it stays within its stated bracket of the exact clearance, is 0 exactly
// in contact, and the certificates taken with it are certificates with exact clearances.
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
#include "core/common/error.h"
#include "core/merge/merge.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"
#include "core/path/path.h"
#include "tests/unit/mesh_problems.h"

namespace hgraph {
namespace {

using testing::LoadWorld;
using testing::MeshProblem;
using testing::MeshProblems;

const std::string kRoot = HGRAPH_SOURCE_DIR;

// min(exact / (1 + rel), cap) <= bound <= min(exact, cap), and 0 exactly in contact, for random
// states (most of them in contact or near it) and for caps below and above the clearance.
TEST(EarlyStopTest, TheBoundStaysWithinItsBracket) {
  constexpr double kTolerance = 1e-9;
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    auto exact_context = world->MakeContext();
    auto context = world->MakeContext();
    std::mt19937_64 rng(7);
    int free = 0;
    int loose = 0;  // free states where the bound is below the exact clearance
    for (int i = 0; i < 400; ++i) {
      const Config q = world->space().Sample(rng);
      const double exact = exact_context->Clearance(q);
      for (const double rel : {0.1, 0.5}) {
        for (const double cap : {1e9, 0.5 * exact + 1e-3}) {
          const double lower = context->ClearanceLowerBound(q, rel, cap);
          ASSERT_EQ(lower == 0, exact == 0) << "state " << i << " exact " << exact;
          EXPECT_LE(lower, std::min(exact, cap) * (1 + kTolerance)) << "state " << i;
          EXPECT_GE(lower, std::min(exact / (1 + rel), cap) * (1 - kTolerance)) << "state " << i;
          if (exact > 0 && cap == 1e9 && lower < exact * (1 - kTolerance)) ++loose;
        }
      }
      if (exact > 0) ++free;
    }
    ASSERT_GT(free, 20);
    EXPECT_EQ(context->distance_queries(), 400 * 4);
    std::printf("%s: %d free states of 400, bound below the exact clearance in %d of %d\n",
                p.name.c_str(), free, loose, 2 * free);
  }
}

// Certificates on the early-stopped bound are certificates: what it certifies has an exact
// certified profile, what it finds in collision collides.
TEST(EarlyStopTest, CertificatesOnTheBoundAreExactCertificates) {
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    const LocalPlanner exact(world, {.direction_bound = false});
    const LocalPlanner early(world, {.certificate_rel_err = 0.25, .direction_bound = false});
    std::mt19937_64 rng(11);
    std::vector<Config> free;
    while (free.size() < 40) {
      const Config q = world->space().Sample(rng);
      if (exact.Clearance(q) > 0) free.push_back(q);
    }
    int certified = 0;
    int certified_exactly = 0;
    for (size_t i = 0; i + 1 < free.size(); ++i) {
      // Short motions (a tenth of the way to the next state) are mostly free; long ones mostly
      // collide.
      const Config to = world->space().Interpolate(free[i], free[i + 1], i % 2 ? 0.1 : 1.0);
      for (const EdgeProof mode : {EdgeProof::kCertificate, EdgeProof::kCertificateOrGiveUp}) {
        const EdgeCheckRequest request{.from = &free[i], .to = &to, .proof = mode};
        const EdgeReport with = early.CheckEdge(request);
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
        }
        if (without.certified) ++certified_exactly;
      }
    }
    // As many certificates as exact distances give, give or take a stalled halving.
    EXPECT_GT(certified, 5);
    EXPECT_GE(certified, certified_exactly * 9 / 10);
    std::printf("%s: %d certified with the early stop, %d with exact distances\n", p.name.c_str(),
                certified, certified_exactly);
  }
}

// Threshold queries (the default) change what a certificate costs, never what it decides: the
// same verdict, the same point of contact, the same number of queries as unbounded distances.
TEST(EarlyStopTest, ThresholdCertificatesDecideAsUnboundedOnes) {
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    const LocalPlanner threshold(world, {.direction_bound = false});
    const LocalPlanner unbounded(world, {.certificate_threshold = false, .direction_bound = false});
    std::mt19937_64 rng(13);
    int certified = 0;
    int invalid = 0;
    for (int i = 0; i < 60; ++i) {
      const Config from = world->space().Sample(rng);
      const Config far = world->space().Sample(rng);
      const Config to = world->space().Interpolate(from, far, i % 2 ? 0.1 : 1.0);
      for (const EdgeProof mode : {EdgeProof::kCertificate, EdgeProof::kCertificateOrGiveUp}) {
        const EdgeCheckRequest request{.from = &from, .to = &to, .proof = mode};
        const EdgeReport a = threshold.CheckEdge(request);
        const EdgeReport b = unbounded.CheckEdge(request);
        EXPECT_EQ(a.state, b.state) << "motion " << i;
        EXPECT_EQ(a.certified, b.certified) << "motion " << i;
        EXPECT_EQ(a.invalid_at, b.invalid_at) << "motion " << i;
        EXPECT_EQ(a.collision_checks, b.collision_checks) << "motion " << i;
        EXPECT_EQ(a.distance_queries, b.distance_queries) << "motion " << i;
        certified += a.certified;
        invalid += a.state == EdgeState::kInvalid;
      }
    }
    // Both kinds of answer were compared.
    EXPECT_GT(certified, 5);
    EXPECT_GT(invalid, 5);
  }
}

// A query started from a witness (CollisionContext::ClearanceFrom) answers min(Clearance, cap),
// whatever the witness: one found near the state (as along a motion), one found far from it, or
// none; and it leaves a witness whose points are as far apart as the answer.
TEST(EarlyStopTest, QueriesFromAWitnessAnswerTheClearanceUpToTheCap) {
  constexpr double kTolerance = 1e-9;
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    const Space& space = world->space();
    auto exact_context = world->MakeContext();
    auto context = world->MakeContext();
    std::mt19937_64 rng(17);
    int free = 0;
    int witnessed = 0;
    for (int i = 0; i < 300; ++i) {
      const Config q = space.Sample(rng);
      const double exact = exact_context->Clearance(q);
      // A witness from a state a few hundredths of the space's extent away, one from a random
      // state, and none.
      const Config near = space.Interpolate(q, space.Sample(rng), 0.02);
      const Config far = space.Sample(rng);
      for (int kind = 0; kind < 3; ++kind) {
        ClearanceWitness hint;
        if (kind < 2) exact_context->Clearance(kind == 0 ? near : far, &hint);
        for (const double cap : {std::numeric_limits<double>::infinity(), 0.5 * exact + 1e-3}) {
          ClearanceWitness w = hint;
          const double got = context->ClearanceFrom(q, cap, &w);
          ASSERT_EQ(got == 0, exact == 0) << "state " << i;
          const double want = std::min(exact, cap);
          EXPECT_NEAR(got, want, kTolerance * (1 + want)) << "state " << i << " kind " << kind;
          if (got > 0 && got < cap && w.body >= 0) {
            std::vector<Eigen::Isometry3d> poses;
            for (int b = 0; b < static_cast<int>(world->scene().robot.size()); ++b) {
              poses.push_back(world->BodyPose(b, q));
            }
            EXPECT_NEAR(CollisionWorld::WitnessDistance(w, poses), got, 1e-6 * (1 + got))
                << "state " << i;
            ++witnessed;
          }
        }
      }
      free += exact > 0;
    }
    EXPECT_GT(free, 20);
    EXPECT_GT(witnessed, 20);
    EXPECT_EQ(context->distance_queries(), 300 * 3 * 2);
  }
}

// Warm starts (the default) change what a check costs, never what it finds: the same verdict,
// certificate, point of contact and counts as queries started afresh, and the same profile.
TEST(EarlyStopTest, WarmStartedChecksDecideAsColdOnes) {
  for (const MeshProblem& p : MeshProblems()) {
    SCOPED_TRACE(p.name);
    const auto world = LoadWorld(p);
    const LocalPlanner warm(world, {.direction_bound = false});
    const LocalPlanner cold(world, {.warm_start = false, .direction_bound = false});
    std::mt19937_64 rng(19);
    int certified = 0;
    int invalid = 0;
    int profiled = 0;
    for (int i = 0; i < 120; ++i) {
      const Config from = world->space().Sample(rng);
      const Config far = world->space().Sample(rng);
      const Config to = world->space().Interpolate(from, far, i % 2 ? 0.1 : 1.0);
      for (const EdgeProof mode :
           {EdgeProof::kCertificate, EdgeProof::kCertificateOrGiveUp, EdgeProof::kProfile}) {
        const EdgeCheckRequest request{.from = &from, .to = &to, .proof = mode};
        const EdgeReport a = warm.CheckEdge(request);
        const EdgeReport b = cold.CheckEdge(request);
        EXPECT_EQ(a.state, b.state) << "motion " << i;
        EXPECT_EQ(a.certified, b.certified) << "motion " << i;
        EXPECT_EQ(a.invalid_at, b.invalid_at) << "motion " << i;
        EXPECT_EQ(a.collision_checks, b.collision_checks) << "motion " << i;
        EXPECT_EQ(a.distance_queries, b.distance_queries) << "motion " << i;
        ASSERT_EQ(a.profile.size(), b.profile.size()) << "motion " << i;
        for (size_t k = 0; k < a.profile.size(); ++k) {
          EXPECT_EQ(a.profile[k].t, b.profile[k].t);
          EXPECT_NEAR(a.profile[k].clearance, b.profile[k].clearance,
                      1e-9 * (1 + b.profile[k].clearance));
        }
        certified += a.certified;
        invalid += a.state == EdgeState::kInvalid;
        profiled += !a.profile.empty();
      }
    }
    EXPECT_GT(certified, 5);
    EXPECT_GT(invalid, 5);
    EXPECT_GT(profiled, 2);
  }
}

// A default merge of the bench's fixed home inputs on a checker whose certificates take the
// early-stopped bound: its path passes CheckPaths on an exact checker, certified, and is as
// short as the exact checker's to within the post-optimization's randomness.
TEST(EarlyStopTest, MergedPathsOnTheBoundAreCertifiedExactly) {
  const MeshProblem p = MeshProblems()[3];
  const auto world = LoadWorld(p);
  const LocalPlanner exact(world, {.direction_bound = false});
  const LocalPlanner early(world, {.certificate_rel_err = 0.25, .direction_bound = false});
  const std::vector<InputPath> inputs =
      LoadPathsFile(kRoot + "/tests/bench/results/real/inputs/home.json", world->space());
  const MergeResult merged = Merge(early, MergeRequest{.paths = inputs});
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

TEST(EarlyStopTest, OptionsAreChecked) {
  const auto world = LoadWorld(MeshProblems()[0]);
  for (const double bad :
       {-0.1, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    try {
      LocalPlanner planner(world, {.certificate_rel_err = bad});
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), "certificate_rel_err");
    }
  }
}

}  // namespace
}  // namespace hgraph
