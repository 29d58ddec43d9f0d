// Property tests of the whole merge on a real scene (FCL, the local planner): for every variant
// and measure, the merged path is valid, keeps the endpoints and is never worse than the best
// valid input.
#include "core/merge/merge.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <mutex>
#include <random>

#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/common/limits.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"
#include "tests/unit/test_scenes.h"

namespace hgraph {
namespace {

using testing::CirclePaths;
using testing::CirclesScene;

class MergeTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    world_ =
        new std::shared_ptr<const CollisionWorld>(std::make_shared<CollisionWorld>(CirclesScene()));
  }
  static void TearDownTestSuite() {
    delete world_;
    world_ = nullptr;
  }
  LocalPlanner MakePlanner() const { return LocalPlanner(*world_); }
  // Every edge of the path passes the local planner.
  static void ExpectValid(const LocalPlanner& planner, const InputPath& path) {
    for (size_t j = 0; j + 1 < path.waypoints.size(); ++j) {
      const EdgeReport r = planner.CheckEdge(
          {.from = &path.waypoints[j], .to = &path.waypoints[j + 1], .proof = EdgeProof::kSamples});
      EXPECT_EQ(r.state, EdgeState::kValid) << "edge " << j;
    }
  }
  // Random variations of the OMPL paths: interior waypoints moved while every edge stays valid.
  std::vector<InputPath> PerturbedPaths(const LocalPlanner& planner, uint64_t seed, int count) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> jitter(0.0, 2.0);
    const std::vector<InputPath> base = CirclePaths();
    std::vector<InputPath> out;
    for (int c = 0; c < count; ++c) {
      InputPath path = base[c % base.size()];
      path.name = "perturbed" + std::to_string(c);
      for (size_t j = 1; j + 1 < path.waypoints.size(); ++j) {
        for (int attempt = 0; attempt < 20; ++attempt) {
          Config moved = path.waypoints[j] + Eigen::Vector2d(jitter(rng), jitter(rng));
          const EdgeReport a = planner.CheckEdge({.from = &path.waypoints[j - 1], .to = &moved});
          const EdgeReport b = planner.CheckEdge({.from = &moved, .to = &path.waypoints[j + 1]});
          if (a.state == EdgeState::kValid && b.state == EdgeState::kValid) {
            path.waypoints[j] = moved;
            break;
          }
        }
      }
      out.push_back(path);
    }
    return out;
  }

  static std::shared_ptr<const CollisionWorld>* world_;
};

// The largest minimum clearance among the valid inputs (certified CheckPaths): half of it is a
// safety some input keeps with room to spare, so that a safe-length merge must find a path.
double SafestInputClearance(const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
  double safest = 0;
  for (const InputReport& report : CheckPaths(planner, {.paths = inputs}).paths) {
    if (report.valid) safest = std::max(safest, report.quality.min_clearance);
  }
  return safest;
}

std::shared_ptr<const CollisionWorld>* MergeTest::world_ = nullptr;

TEST_F(MergeTest, OmplCirclePathsMergeIntoAShorterValidPath) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = CirclePaths();
  ASSERT_EQ(inputs.size(), 2u);
  const MergeResult r = Merge(planner, MergeRequest{.paths = inputs});
  ASSERT_EQ(r.inputs.size(), 2u);
  EXPECT_TRUE(r.inputs[0].valid);
  EXPECT_TRUE(r.inputs[1].valid);
  EXPECT_LT(r.quality.length, r.inputs[0].quality.length);
  EXPECT_LT(r.quality.length, r.inputs[1].quality.length);
  ExpectValid(planner, r.path);
  EXPECT_TRUE(r.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
  EXPECT_TRUE(r.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
  EXPECT_GT(r.stats.collision_checks, 0);
  EXPECT_GT(r.stats.distance_queries, 0);
}

TEST_F(MergeTest, LengthMergeProfilesItsPathOnlyOnRequest) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = CirclePaths();
  const MergeResult plain = Merge(planner, MergeRequest{.paths = inputs});
  const MergeResult profiled =
      Merge(planner, MergeRequest{.paths = inputs, .options = {.report_clearance = true}});
  // The same certified path; only the report differs.
  ASSERT_EQ(plain.path.waypoints.size(), profiled.path.waypoints.size());
  for (size_t i = 0; i < plain.path.waypoints.size(); ++i) {
    EXPECT_TRUE(plain.path.waypoints[i].isApprox(profiled.path.waypoints[i])) << i;
  }
  EXPECT_DOUBLE_EQ(plain.quality.length, profiled.quality.length);
  const InputReport check = CheckPaths(planner, {.paths = {plain.path}}).paths.at(0);
  ASSERT_TRUE(check.valid && check.certified);
  EXPECT_FALSE(plain.quality.has_clearance);
  EXPECT_EQ(plain.quality.min_clearance, 0);
  EXPECT_EQ(plain.quality.avg_clearance, 0);
  EXPECT_TRUE(profiled.quality.has_clearance);
  EXPECT_GT(profiled.quality.min_clearance, 0);
  // Both profiles sample the same motions; refinements may differ where they start from.
  EXPECT_NEAR(profiled.quality.min_clearance, check.quality.min_clearance,
              0.01 * check.quality.min_clearance);
  EXPECT_LT(plain.stats.distance_queries, profiled.stats.distance_queries);
  // A measure of clearance profiles its path without being asked.
  const MergeResult widest =
      Merge(planner,
            MergeRequest{.paths = inputs, .measure = {.type = MeasureType::kBottleneckClearance}});
  EXPECT_TRUE(widest.quality.has_clearance);
  EXPECT_GT(widest.quality.min_clearance, 0);
}

// A sampled merge (MergeOptions::check_mode kSampled) checks every motion at its samples only,
// as OMPL's discrete motion validator does: under length not one distance query (the H-Graph's
// edges, bridges and the post-optimization's shortcuts and restarts alike), and the result says
// it is not certified, where the default pays distance queries for its certificate and says so.
// Its path passes the sampled check of CheckPaths, keeps the endpoints and is no longer than the
// best input.
TEST_F(MergeTest, SampledMergeChecksSamplesOnlyAndSaysSo) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = PerturbedPaths(planner, 1, 4);
  double shortest_input = INFINITY;
  for (const InputPath& input : inputs) {
    shortest_input = std::min(shortest_input, PathLength(planner.space(), input));
  }
  const MergeResult certified = Merge(planner, MergeRequest{.paths = inputs});
  EXPECT_EQ(certified.check_mode, CheckMode::kCertified);
  EXPECT_GT(certified.stats.distance_queries, 0);
  const InputReport certified_check = CheckPaths(planner, {.paths = {certified.path}}).paths.at(0);
  EXPECT_TRUE(certified_check.valid && certified_check.certified);
  for (const MergeOptions& options :
       {MergeOptions{.check_mode = CheckMode::kSampled},
        MergeOptions{.candidates = {.variant = Variant::kAllPairs},
        .check_mode = CheckMode::kSampled},
        MergeOptions{.check_mode = CheckMode::kSampled, .optimize_restarts = 2}}) {
    SCOPED_TRACE(std::string(VariantName(options.candidates.variant)) + ", restarts " +
                 std::to_string(options.optimize_restarts));
    const MergeResult r = Merge(planner, MergeRequest{.paths = inputs, .options = options});
    EXPECT_EQ(r.check_mode, CheckMode::kSampled);
    EXPECT_EQ(r.stats.distance_queries, 0);
    EXPECT_EQ(r.stats.node_clearances, 0);
    EXPECT_GT(r.stats.collision_checks, 0);
    EXPECT_GT(r.stats.optimize_rounds, 0);
    EXPECT_FALSE(r.quality.has_clearance);
    const InputReport check =
        CheckPaths(planner, {.paths = {r.path}, .mode = CheckMode::kSampled}).paths.at(0);
    EXPECT_TRUE(check.valid) << check.invalid_reason;
    EXPECT_FALSE(check.certified);
    ASSERT_GE(r.path.waypoints.size(), 2u);
    EXPECT_TRUE(r.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
    EXPECT_TRUE(r.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
    EXPECT_LE(r.quality.length, shortest_input + 1e-9);
    EXPECT_NEAR(r.quality.length, check.quality.length, 1e-9 * check.quality.length);
    EXPECT_LE(r.objective, r.hgraph_objective + 1e-9);
    if (options.candidates.variant == Variant::kEditDistance) {
      // Every motion the certified merge may use, the sampled one may too: its H-Graph optimum
      // is never longer.
      EXPECT_LE(r.hgraph_objective, certified.hgraph_objective + 1e-9);
    }
  }
}

// The measures of clearance in a sampled merge still compute the clearances their values are
// made of, and take a motion valid at its samples: the same guarantees of the path (valid at
// its samples, the endpoints, no worse than the best input), marked not certified; a requery of
// its H-Graph keeps the mode.
TEST_F(MergeTest, SampledMergeUnderClearanceMeasuresKeepsTheInvariants) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = PerturbedPaths(planner, 2, 4);
  const double safest_input = SafestInputClearance(planner, inputs);
  ASSERT_GT(safest_input, 0);
  HybridizationSession session(
      planner, MergeRequest{.paths = inputs,
                            .options = {.check_mode = CheckMode::kSampled, .report_inputs = true}});
  for (const MeasureSpec& measure :
       {MeasureSpec{.type = MeasureType::kBottleneckClearance},
        MeasureSpec{.type = MeasureType::kInverseClearance, .k = 3},
        MeasureSpec{.type = MeasureType::kSafeLength, .safety = 0.5 * safest_input},
        MeasureSpec{.type = MeasureType::kLength}}) {
    SCOPED_TRACE(MeasureTypeName(measure.type));
    const MergeResult r = session.Query(measure);
    EXPECT_EQ(r.check_mode, CheckMode::kSampled);
    const InputReport check =
        CheckPaths(planner, {.paths = {r.path}, .mode = CheckMode::kSampled}).paths.at(0);
    EXPECT_TRUE(check.valid) << check.invalid_reason;
    EXPECT_TRUE(r.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
    EXPECT_TRUE(r.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
    ASSERT_GE(r.best_input, 0);
    EXPECT_LE(r.objective, r.best_input_objective + 1e-9 * (1 + std::abs(r.best_input_objective)));
    if (measure.type != MeasureType::kLength) {
      EXPECT_TRUE(r.quality.has_clearance);
      EXPECT_GT(r.quality.min_clearance, 0);
    }
    if (measure.type == MeasureType::kSafeLength) {
      EXPECT_GE(r.quality.min_clearance, measure.safety);
    }
  }
}

struct Case {
  Variant variant;
  MeasureSpec measure;
};

class MergePropertyTest : public MergeTest, public ::testing::WithParamInterface<uint64_t> {};

TEST_P(MergePropertyTest, EveryVariantAndMeasureKeepsTheInvariants) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = PerturbedPaths(planner, GetParam(), 4);
  // A safety some input meets, so that every variant must find a safe path (the merge is never
  // worse than its best input), and one no configuration of the scene meets.
  const double safest_input = SafestInputClearance(planner, inputs);
  ASSERT_GT(safest_input, 0);
  const std::vector<MeasureSpec> measures = {
      {.type = MeasureType::kLength},
      {.type = MeasureType::kInverseClearance, .k = 3},
      {.type = MeasureType::kInverseClearance, .k = 0.25},
      {.type = MeasureType::kBottleneckClearance},
      {.type = MeasureType::kSafeLength, .safety = 0.5 * safest_input},
  };
  for (const MeasureSpec& measure : measures) {
    double all_pairs_objective = 0;
    for (Variant variant : {Variant::kAllPairs, Variant::kNeighborhood, Variant::kKNearest,
                            Variant::kEditDistance, Variant::kEditDistanceNeighborhood}) {
      SCOPED_TRACE(std::string(VariantName(variant)) + " / " + MeasureTypeName(measure.type));
      // Lazy with every input reported, lazy alone, eager: same candidates, same checks. Every
      // measure here (the safety is one some input meets) has a path in every mode.
      std::vector<MergeResult> runs;
      for (const MergeOptions& options :
           {MergeOptions{.candidates = {.variant = variant}, .report_inputs = true},
            MergeOptions{.candidates = {.variant = variant}},
            MergeOptions{.candidates = {.variant = variant}, .evaluation = Evaluation::kEager}}) {
        runs.push_back(
            Merge(planner, MergeRequest{.paths = inputs, .measure = measure, .options = options}));
      }
      if (measure.type == MeasureType::kSafeLength) {
        // A safety nothing in the scene meets fails, naming the field.
        try {
          Merge(planner, MergeRequest{.paths = inputs,
                                      .measure = {.type = MeasureType::kSafeLength, .safety = 1e3},
                                      .options = {.candidates = {.variant = variant}}});
          ADD_FAILURE() << "a safety of 1e3 was met";
        } catch (const Error& e) {
          EXPECT_EQ(e.code(), ErrorCode::kFailedPrecondition) << e.what();
          EXPECT_EQ(e.field(), "measure.safety") << e.what();
        }
      }
      for (const MergeResult& r : runs) {
        ExpectValid(planner, r.path);
        // Certified as `hgraph check` certifies: every stretch proven free.
        const InputReport check = CheckPaths(planner, {.paths = {r.path}}).paths.at(0);
        EXPECT_TRUE(check.valid && check.certified);
        EXPECT_TRUE(r.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
        EXPECT_TRUE(r.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
        // Under length the path is profiled only on request (MergeOptions::report_clearance).
        EXPECT_EQ(r.quality.has_clearance, measure.type != MeasureType::kLength);
        EXPECT_GT(check.quality.min_clearance, 0);
        if (r.quality.has_clearance) {
          EXPECT_GT(r.quality.min_clearance, 0);
        }
        for (const InputReport& input : r.inputs) {
          if (input.valid && input.checked) {
            EXPECT_FALSE(Better(measure, input.quality, r.quality)) << input.name;
          }
        }
      }
      const MergeResult& reported = runs[0];
      const MergeResult& lazy = runs[1];
      const MergeResult& eager = runs[2];
      for (const MergeResult* r : {&reported, &eager}) {
        ASSERT_GE(r->best_input, 0);
        EXPECT_LE(r->objective, r->best_input_objective + 1e-9);
        for (const InputReport& input : r->inputs) EXPECT_TRUE(input.checked);
      }
      // Lazy returns the eager H-Graph optimum: exactly for length and bottleneck clearance
      // (their bounds are exact or attained), never worse for the others.
      const double eps = 1e-9 * (1 + std::abs(eager.hgraph_objective));
      if (measure.type == MeasureType::kLength ||
          measure.type == MeasureType::kBottleneckClearance) {
        EXPECT_NEAR(lazy.hgraph_objective, eager.hgraph_objective, eps);
      } else {
        EXPECT_LE(lazy.hgraph_objective, eager.hgraph_objective + eps);
      }
      EXPECT_NEAR(reported.hgraph_objective, lazy.hgraph_objective, eps);
      EXPECT_LE(lazy.stats.edges_checked, eager.stats.edges_checked);
      for (const MergeResult& r : runs) {
        // The post-optimization never makes the H-Graph optimum worse; it runs for length only
        // among these measures (and safe length).
        EXPECT_LE(r.objective, r.hgraph_objective + eps);
        if (measure.type == MeasureType::kLength) {
          EXPECT_GT(r.stats.optimize_rounds, 0);
        }
        if (measure.type == MeasureType::kInverseClearance ||
            measure.type == MeasureType::kBottleneckClearance) {
          EXPECT_EQ(r.objective, r.hgraph_objective);
          EXPECT_EQ(r.stats.optimize_rounds, 0);
        }
      }
      if (variant == Variant::kAllPairs) {
        all_pairs_objective = eager.hgraph_objective;
      } else {
        EXPECT_LE(all_pairs_objective, eager.hgraph_objective + 1e-9) << "all-pairs is never worse";
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, MergePropertyTest, ::testing::Values(1, 2, 3));

// Four PRM paths on the grid scene (hgraph-bench, seed 1) whose shortcuts and bridges graze
// obstacles: sampled-valid motions the clearance profile cannot certify. The merge used to return
// one of them; every mode must now route around them and return a certified path.
TEST(MergeCertifiedTest, GrazingMotionsNeverReachTheOutput) {
  const auto scene = LoadSceneFile(std::string(HGRAPH_SOURCE_DIR) + "/scenes/grid/scene.json");
  const LocalPlanner planner(std::make_shared<CollisionWorld>(scene),
                             LocalPlannerOptions{.resolution = 0.002});
  const std::vector<InputPath> inputs =
      LoadPathsFile(std::string(HGRAPH_TEST_DATA_DIR) + "/grid/prm4_seed1.json", planner.space());
  ASSERT_EQ(inputs.size(), 4u);
  double shortest_input = INFINITY;
  for (const InputReport& input : CheckPaths(planner, {.paths = inputs}).paths) {
    shortest_input = std::min(shortest_input, input.quality.length);
  }
  double certified_optimum = NAN;
  for (const MergeOptions& options :
       {MergeOptions{}, MergeOptions{.evaluation = Evaluation::kEager},
        MergeOptions{.candidates = {.variant = Variant::kAllPairs}}}) {
    const MergeResult r = Merge(planner, MergeRequest{.paths = inputs, .options = options});
    const InputReport check = CheckPaths(planner, {.paths = {r.path}}).paths.at(0);
    EXPECT_TRUE(check.valid);
    EXPECT_TRUE(check.certified) << "min clearance " << check.quality.min_clearance;
    EXPECT_LT(r.quality.length, shortest_input);
    if (options.evaluation == Evaluation::kLazy &&
        options.candidates.variant == Variant::kEditDistance) {
      certified_optimum = r.hgraph_objective;
    }
  }
  // A sampled merge may take the grazing motions (valid at their samples): its path passes the
  // sampled check, and with more motions to use its H-Graph optimum is never longer.
  const MergeResult sampled =
      Merge(planner, MergeRequest{.paths = inputs, .options = {.check_mode = CheckMode::kSampled}});
  EXPECT_EQ(sampled.check_mode, CheckMode::kSampled);
  EXPECT_EQ(sampled.stats.distance_queries, 0);
  const InputReport check =
      CheckPaths(planner, {.paths = {sampled.path}, .mode = CheckMode::kSampled}).paths.at(0);
  EXPECT_TRUE(check.valid) << check.invalid_reason;
  EXPECT_TRUE(sampled.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
  EXPECT_TRUE(sampled.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
  EXPECT_LT(sampled.quality.length, shortest_input);
  EXPECT_LE(sampled.hgraph_objective, certified_optimum + 1e-9);
}

// The mesh problems (the wrench among boxes; the rod through the holed wall, mesh against mesh)
// with their four PRM inputs (hgraph-bench, seed 1): `test` runs on each, traced by scene.
void ForMeshProblems(
    const std::function<void(const LocalPlanner&, const std::vector<InputPath>&)>& test) {
  for (const auto& [scene_file, inputs_file] :
       {std::pair<std::string, std::string>{"/scenes/wrench/scene.json", "/wrench/prm4_seed1.json"},
        {"/tests/bench/scenes/hole_wall/scene.json", "/hole_wall/prm4_seed1.json"}}) {
    SCOPED_TRACE(scene_file);
    const std::string path = std::string(HGRAPH_SOURCE_DIR) + scene_file;
    const LocalPlanner planner(std::make_shared<CollisionWorld>(LoadSceneFile(path)),
                               {.resolution = SceneResolution(ReadSceneFile(path))});
    const std::vector<InputPath> inputs =
        LoadPathsFile(std::string(HGRAPH_TEST_DATA_DIR) + inputs_file, planner.space());
    ASSERT_EQ(inputs.size(), 4u);
    test(planner, inputs);
  }
}

// Lazy inverse clearance on the mesh problems, where the ends' and probes' witnesses bound the
// unchecked edges: the same
// H-Graph optimum as eager, for fewer distance queries. A ceiling below some clearance would
// make lazy skip the optimum and return a costlier path.
TEST(MergeMeshTest, LazyInverseClearanceFindsTheEagerOptimumOnMeshes) {
  ForMeshProblems([](const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
    std::vector<MergeResult> runs;
    for (Evaluation evaluation : {Evaluation::kLazy, Evaluation::kEager}) {
      runs.push_back(
          Merge(planner, MergeRequest{.paths = inputs,
                                      .measure = {.type = MeasureType::kInverseClearance, .k = 3},
                                      .options = {.evaluation = evaluation, .optimize_ms = 0}}));
    }
    const MergeResult& lazy = runs[0];
    const MergeResult& eager = runs[1];
    EXPECT_NEAR(lazy.objective, eager.objective, 1e-9 * eager.objective);
    EXPECT_LT(lazy.stats.distance_queries, eager.stats.distance_queries);
    const InputReport check = CheckPaths(planner, {.paths = {lazy.path}}).paths.at(0);
    EXPECT_TRUE(check.valid && check.certified);
  });
}

// Partial shortcuts (MergeOptions::partial_shortcuts) on real meshes (SE(3)), under length and
// safe length: the merge keeps its invariants (certified, the endpoints, never worse than its
// best input or its H-Graph optimum), and under length its result is another than without
// them.
TEST(MergeMeshTest, PartialShortcutsKeepTheInvariants) {
  ForMeshProblems([](const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
    const double safest_input = SafestInputClearance(planner, inputs);
    ASSERT_GT(safest_input, 0);
    for (const MeasureSpec& measure :
         {MeasureSpec{.type = MeasureType::kLength},
          MeasureSpec{.type = MeasureType::kSafeLength, .safety = 0.5 * safest_input}}) {
      SCOPED_TRACE(MeasureTypeName(measure.type));
      std::vector<MergeResult> runs;
      for (bool partial : {false, true}) {
        runs.push_back(Merge(planner, MergeRequest{.paths = inputs,
                                                   .measure = measure,
                                                   .options = {.report_inputs = true,
                                                               .partial_shortcuts = partial}}));
      }
      const MergeResult& r = runs[1];
      const InputReport check = CheckPaths(planner, {.paths = {r.path}}).paths.at(0);
      EXPECT_TRUE(check.valid && check.certified);
      EXPECT_TRUE(r.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
      EXPECT_TRUE(r.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
      ASSERT_GE(r.best_input, 0);
      EXPECT_LE(r.objective, r.best_input_objective + 1e-9);
      EXPECT_LE(r.objective, r.hgraph_objective + 1e-9);
      EXPECT_GT(r.stats.shortcuts, 0);
      // Under length the shortcuts went elsewhere. (Under this safety both runs end at the same
      // path on these inputs.)
      if (measure.type == MeasureType::kLength) {
        EXPECT_NE(r.path.waypoints, runs[0].path.waypoints);
      }
    }
  });
}

// MergeOptions::optimize_ms on the mesh problems, under length: budgets that end inside the first
// round (its shortcuts, its search) or in a later one. Wherever the budget ends, the answer is
// certified, keeps the endpoints and is no worse than the H-Graph's optimum; a budget that ended
// says so (kTime), one the rounds outlived says why they stopped. Only what stopped the rounds is
// checked, never how long they took.
TEST(MergeMeshTest, ABudgetEndingInsideARoundKeepsTheBestCertifiedPath) {
  ForMeshProblems([](const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
    for (const double budget_ms : {0.5, 2.0, 8.0, 30.0}) {
      SCOPED_TRACE(budget_ms);
      const MergeResult r =
          Merge(planner, MergeRequest{.paths = inputs, .options = {.optimize_ms = budget_ms}});
      const InputReport check = CheckPaths(planner, {.paths = {r.path}}).paths.at(0);
      EXPECT_TRUE(check.valid && check.certified);
      EXPECT_TRUE(r.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
      EXPECT_TRUE(r.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
      EXPECT_LE(r.objective, r.hgraph_objective + 1e-9);
      EXPECT_NEAR(r.objective, check.quality.length, 1e-6 * check.quality.length);
      EXPECT_TRUE(r.stats.optimize_stop == OptimizeStop::kTime ||
                  r.stats.optimize_stop == OptimizeStop::kConverged ||
                  r.stats.optimize_stop == OptimizeStop::kGrowth)
          << OptimizeStopName(r.stats.optimize_stop);
    }
  });
}

// MergeOptions::give_up_stalled on the mesh problems (on: with and without restarts): whether the
// post-optimization's searches refuse motions whose certificate stalls or profile them, the answer
// is certified, keeps the endpoints and is no worse than the H-Graph's optimum, and the same
// on one thread as on two.
TEST(MergeMeshTest, SearchesThatRefuseStalledMotionsKeepTheInvariants) {
  ForMeshProblems([](const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
    for (const auto& [give_up, restarts] : {std::pair{true, -1}, {true, 2}, {false, -1}}) {
      SCOPED_TRACE(::testing::Message() << "give_up " << give_up << ", restarts " << restarts);
      std::vector<MergeResult> runs;
      for (const int threads : {1, 2}) {
        runs.push_back(Merge(planner, MergeRequest{.paths = inputs,
                                                   .options = {.optimize_restarts = restarts,
                                                               .give_up_stalled = give_up,
                                                               .threads = threads}}));
      }
      const MergeResult& r = runs[0];
      const InputReport check = CheckPaths(planner, {.paths = {r.path}}).paths.at(0);
      EXPECT_TRUE(check.valid && check.certified);
      EXPECT_TRUE(r.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
      EXPECT_TRUE(r.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
      EXPECT_LE(r.objective, r.hgraph_objective + 1e-9);
      EXPECT_EQ(runs[1].path.waypoints, r.path.waypoints);
    }
  });
}

// Restarts (MergeOptions::optimize_restarts) on the mesh problems, stopped by the automatic
// budget's rounds, never the clock: none gives the default merge's path; two keep the invariants
// (certified, the endpoints, never worse than without them, under length and safe length) and give
// the same path on one thread as on two (the count, not the machine, decides); on the rod through
// the holed wall they lead out of the defaults' local optimum into a shorter one.
TEST(MergeMeshTest, RestartsKeepTheInvariantsAndLeaveALocalOptimum) {
  bool left_an_optimum = false;
  ForMeshProblems([&](const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
    const double safety = 0.5 * SafestInputClearance(planner, inputs);
    for (const MeasureSpec& measure :
         {MeasureSpec{.type = MeasureType::kLength},
          MeasureSpec{.type = MeasureType::kSafeLength, .safety = safety}}) {
      SCOPED_TRACE(MeasureTypeName(measure.type));
      const auto merge = [&](int restarts, int threads) {
        return Merge(planner,
                     MergeRequest{.paths = inputs,
                                  .measure = measure,
                                  .options = {.optimize_restarts = restarts, .threads = threads}});
      };
      const MergeResult plain = Merge(planner, MergeRequest{.paths = inputs, .measure = measure});
      EXPECT_EQ(merge(0, 0).path.waypoints, plain.path.waypoints);
      const MergeResult restarted = merge(2, 1);
      const InputReport check = CheckPaths(planner, {.paths = {restarted.path}}).paths.at(0);
      EXPECT_TRUE(check.valid && check.certified);
      EXPECT_TRUE(restarted.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
      EXPECT_TRUE(restarted.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
      EXPECT_LE(restarted.objective, plain.objective + 1e-9);
      EXPECT_GT(restarted.stats.optimize_rounds, plain.stats.optimize_rounds);
      if (measure.type == MeasureType::kSafeLength) {
        EXPECT_GE(check.quality.min_clearance, safety);
      } else {
        EXPECT_EQ(merge(2, 2).path.waypoints, restarted.path.waypoints);
        left_an_optimum = left_an_optimum || restarted.objective < plain.objective * (1 - 1e-3);
      }
    }
  });
  EXPECT_TRUE(left_an_optimum);
}

// On the mesh problems, restarts shorten the inputs lazily (ShortcutRequest::lazy): motions valid
// at their samples join the H-Graph without a certificate, beside the lazy search's own. The
// merge's path and the paths of later queries on the same H-Graph, under every measure, are still
// certified (under safe length keeping the safety; under length no longer than the merge's).
TEST(MergeMeshTest, QueriesAfterLazyRestartsReturnCertifiedPaths) {
  ForMeshProblems([](const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
    HybridizationSession session(
        planner, MergeRequest{.paths = inputs, .options = {.optimize_restarts = 2}});
    const auto expect_certified = [&](const MergeResult& r) {
      const InputReport check = CheckPaths(planner, {.paths = {r.path}}).paths.at(0);
      EXPECT_TRUE(check.valid && check.certified);
      EXPECT_TRUE(r.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
      EXPECT_TRUE(r.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
      return check;
    };
    const InputReport merged = expect_certified(session.Query({}));
    const double safety = 0.5 * SafestInputClearance(planner, inputs);
    for (const MeasureSpec& measure :
         {MeasureSpec{.type = MeasureType::kBottleneckClearance},
          MeasureSpec{.type = MeasureType::kInverseClearance, .k = 3},
          MeasureSpec{.type = MeasureType::kSafeLength, .safety = safety},
          MeasureSpec{.type = MeasureType::kLength}}) {
      SCOPED_TRACE(MeasureTypeName(measure.type));
      const InputReport check = expect_certified(session.Query(measure));
      if (measure.type == MeasureType::kSafeLength) {
        EXPECT_GE(check.quality.min_clearance, safety);
      }
      if (measure.type == MeasureType::kLength) {
        EXPECT_LE(check.quality.length, merged.quality.length + 1e-9);
      }
    }
  });
}

// As many restarts as a request may ask for (100,000), which make the query's overlay dense
// (bridges from every new point to the nodes near it), on the rod through the holed wall: the
// post-optimization stops once it has added limits::kMaxOptimizeNodes nodes or
// kMaxOptimizeEdges edges, long before its rounds run out (the clock is never read), with a
// certified path no worse than the defaults'; the overlay goes with the query, and the same
// query again answers the same.
TEST(MergeMeshTest, PostOptimizationGrowthIsBounded) {
  const std::string scene =
      std::string(HGRAPH_SOURCE_DIR) + "/tests/bench/scenes/hole_wall/scene.json";
  const LocalPlanner planner(std::make_shared<CollisionWorld>(LoadSceneFile(scene)),
                             {.resolution = SceneResolution(ReadSceneFile(scene))});
  const std::vector<InputPath> inputs = LoadPathsFile(
      std::string(HGRAPH_TEST_DATA_DIR) + "/hole_wall/prm4_seed1.json", planner.space());
  const MergeResult plain = Merge(planner, MergeRequest{.paths = inputs});
  HybridizationSession session(
      planner, MergeRequest{.paths = inputs, .options = {.optimize_restarts = 100000}});
  const int nodes = session.graph().num_nodes();
  const int edges = session.graph().num_edges();
  const MergeResult r = session.Query({});
  EXPECT_EQ(r.stats.optimize_stop, OptimizeStop::kGrowth);
  EXPECT_EQ(session.graph().num_nodes(), nodes);
  EXPECT_EQ(session.graph().num_edges(), edges);
  const InputReport check = CheckPaths(planner, {.paths = {r.path}}).paths.at(0);
  EXPECT_TRUE(check.valid && check.certified);
  EXPECT_LE(r.objective, plain.objective + 1e-9);
  const MergeResult again = session.Query({});
  EXPECT_EQ(again.stats.optimize_stop, OptimizeStop::kGrowth);
  EXPECT_EQ(again.stats.optimize_rounds, r.stats.optimize_rounds);
  EXPECT_EQ(again.path.waypoints, r.path.waypoints);
}

// MergeOptions::progress_paths on the mesh problems, under length and safe length: every event
// of the post-optimization carries its path, the best so far, which a caller who stops the merge
// may take as it is: certified, keeping the safety, from start to goal, with the objective the
// event names; the first is the H-Graph optimum, and the result is no worse than the last.
TEST(MergeMeshTest, ProgressPathsAreCertifiedPathsOfTheirObjective) {
  ForMeshProblems([](const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
    const double safety = 0.5 * SafestInputClearance(planner, inputs);
    ASSERT_GT(safety, 0);
    for (const MeasureSpec& measure :
         {MeasureSpec{.type = MeasureType::kLength},
          MeasureSpec{.type = MeasureType::kSafeLength, .safety = safety}}) {
      SCOPED_TRACE(MeasureTypeName(measure.type));
      std::mutex mu;
      std::vector<Progress> events;
      MergeRequest request{.paths = inputs,
                           .measure = measure,
                           .options = {.progress_paths = true},
                           .progress = [&](const Progress& p) {
                             std::lock_guard<std::mutex> lock(mu);
                             if (p.phase == "optimize") {
                               events.push_back(p);
                             } else {
                               EXPECT_EQ(p.path, nullptr) << p.phase;
                             }
                           }};
      const MergeResult r = Merge(planner, request);
      ASSERT_GE(events.size(), 2u);
      EXPECT_EQ(events.front().done, 0);
      EXPECT_DOUBLE_EQ(events.front().objective, r.hgraph_objective);
      EXPECT_LE(r.objective, events.back().objective + 1e-9);
      for (size_t i = 0; i < events.size(); ++i) {
        SCOPED_TRACE("event " + std::to_string(i));
        const Progress& e = events[i];
        if (i > 0) {
          EXPECT_GT(e.done, events[i - 1].done);
          EXPECT_LT(e.objective, events[i - 1].objective);
        }
        ASSERT_NE(e.path, nullptr);
        const InputPath& path = *e.path;
        ASSERT_GE(path.waypoints.size(), 2u);
        EXPECT_TRUE(path.waypoints.front().isApprox(inputs[0].waypoints.front()));
        EXPECT_TRUE(path.waypoints.back().isApprox(inputs[0].waypoints.back()));
        const InputReport check = CheckPaths(planner, {.paths = {path}}).paths.at(0);
        EXPECT_TRUE(check.valid && check.certified);
        EXPECT_NEAR(check.quality.length, e.objective, 1e-7 * e.objective);
        if (measure.type == MeasureType::kSafeLength) {
          EXPECT_GE(check.quality.min_clearance, safety);
        }
      }
      // The last path streamed is the result's, or the result is better still.
      if (r.objective >= events.back().objective - 1e-12) {
        EXPECT_EQ(events.back().path->waypoints, r.path.waypoints);
      }
    }
  });
}

TEST_F(MergeTest, RequeryReusesEveryCheck) {
  const LocalPlanner planner = MakePlanner();
  HybridizationSession session(
      planner, MergeRequest{.paths = CirclePaths(),
                            .measure = {.type = MeasureType::kInverseClearance, .k = 3},
                            .options = {.evaluation = Evaluation::kEager, .optimize_ms = 0}});
  const MergeResult first = session.Query({.type = MeasureType::kInverseClearance, .k = 3});
  EXPECT_GT(first.stats.distance_queries, 0);
  // Every valid edge already carries its clearance profile: nothing new to check.
  const MergeResult second = session.Query({.type = MeasureType::kBottleneckClearance});
  EXPECT_EQ(second.stats.collision_checks, 0);
  EXPECT_EQ(second.stats.distance_queries, 0);
  EXPECT_EQ(second.stats.edges_checked, 0);
  // Every checked edge of the H-Graph served it as it was.
  int64_t checked = 0;
  for (int e = 0; e < session.graph().num_edges(); ++e) {
    checked += session.graph().edge(e).report.state != EdgeState::kUnchecked;
  }
  EXPECT_EQ(second.stats.edges_reused, checked);
  EXPECT_GE(second.quality.min_clearance, first.quality.min_clearance - 1e-12);
  const MergeResult third = session.Query({.type = MeasureType::kLength});
  EXPECT_EQ(third.stats.collision_checks, 0);
  EXPECT_LE(third.quality.length, second.quality.length + 1e-12);
}

TEST_F(MergeTest, FirstQueryReportsTheBuildAndLaterOnesTheSameShapeWithOnlyTheirOwnWork) {
  const LocalPlanner planner = MakePlanner();
  HybridizationSession session(
      planner,
      MergeRequest{.paths = CirclePaths(),
                   .options = {.candidates = {.variant = Variant::kEditDistanceNeighborhood},
                               .evaluation = Evaluation::kEager,
                               .optimize_ms = 0,
                               .threads = 2}});
  const MergeStats build = session.build_stats();
  ASSERT_GT(build.edges_checked, 0);
  ASSERT_GT(build.alignments, 0);
  ASSERT_GT(build.radius, 0);
  const MergeResult first = session.Query({});
  const MergeResult second = session.Query({});
  // The build's work counts in the first query only, with its phases' timing.
  EXPECT_GE(first.stats.edges_checked, build.edges_checked);
  EXPECT_GE(first.stats.collision_checks, build.collision_checks);
  EXPECT_EQ(first.stats.edges_reused, 0);
  EXPECT_EQ(first.timing.validate_ms, session.build_timing().validate_ms);
  EXPECT_EQ(first.timing.inputs_ms, session.build_timing().inputs_ms);
  EXPECT_EQ(second.stats.edges_checked, 0);
  EXPECT_EQ(second.stats.collision_checks, 0);
  EXPECT_EQ(second.stats.distance_queries, 0);
  EXPECT_GT(second.stats.edges_reused, 0);
  EXPECT_EQ(second.timing.validate_ms, 0);
  EXPECT_EQ(second.timing.inputs_ms, 0);
  EXPECT_EQ(second.timing.align_ms, 0);
  // Every query reports the H-Graph's shape as built.
  for (const MergeStats& stats : {first.stats, second.stats}) {
    EXPECT_EQ(stats.nodes, build.nodes);
    EXPECT_EQ(stats.input_edges, build.input_edges);
    EXPECT_EQ(stats.input_edges_invalid, build.input_edges_invalid);
    EXPECT_EQ(stats.candidate_edges, build.candidate_edges);
    EXPECT_EQ(stats.threads, 2);
    EXPECT_EQ(stats.alignments, build.alignments);
    EXPECT_EQ(stats.radius, build.radius);
    EXPECT_EQ(stats.gap_init, build.gap_init);
    EXPECT_EQ(stats.gap_extend, build.gap_extend);
  }
  EXPECT_EQ(second.stats.edges_valid, first.stats.edges_valid);
}

TEST_F(MergeTest, LengthFirstThenClearancePaysOnlyForMissingProfiles) {
  const LocalPlanner planner = MakePlanner();
  HybridizationSession session(
      planner, MergeRequest{.paths = CirclePaths(),
                            .options = {.evaluation = Evaluation::kEager, .optimize_ms = 0}});
  const MergeResult first = session.Query({});
  const MergeResult second = session.Query({.type = MeasureType::kInverseClearance, .k = 3});
  EXPECT_GT(second.stats.distance_queries, 0);
  EXPECT_GT(second.stats.edges_checked, 0);
  // Edges known valid are not collision-checked again, only measured.
  EXPECT_EQ(second.stats.collision_checks, 0);
  const MergeResult third = session.Query({.type = MeasureType::kInverseClearance, .k = 1});
  EXPECT_EQ(third.stats.distance_queries, 0);
  EXPECT_EQ(third.stats.collision_checks, 0);
  EXPECT_LE(first.quality.length, third.quality.length + 1e-12);
}

TEST_F(MergeTest, LazyRequeryProfilesOnlyWhatItsSearchWants) {
  const LocalPlanner planner = MakePlanner();
  const MergeOptions options{.candidates = {.variant = Variant::kAllPairs}};
  MergeOptions eager_options = options;
  eager_options.evaluation = Evaluation::kEager;
  HybridizationSession lazy(planner, MergeRequest{.paths = CirclePaths(), .options = options});
  HybridizationSession eager(planner,
                             MergeRequest{.paths = CirclePaths(), .options = eager_options});
  const MergeResult lazy_length = lazy.Query({});
  const MergeResult eager_length = eager.Query({});
  EXPECT_NEAR(lazy_length.objective, eager_length.objective, 1e-9);
  EXPECT_LT(lazy_length.stats.edges_checked, eager_length.stats.edges_checked);
  const MergeResult lazy_bottleneck = lazy.Query({.type = MeasureType::kBottleneckClearance});
  const MergeResult eager_bottleneck = eager.Query({.type = MeasureType::kBottleneckClearance});
  EXPECT_NEAR(lazy_bottleneck.objective, eager_bottleneck.objective, 1e-9);
  EXPECT_NEAR(lazy_bottleneck.quality.length, eager_bottleneck.quality.length, 1e-9);
  // Eager profiles every valid edge; lazy the nodes and the edges its searches took.
  EXPECT_LT(lazy_bottleneck.stats.distance_queries, eager_bottleneck.stats.distance_queries);
  EXPECT_GT(lazy_bottleneck.stats.node_clearances, 0);
  EXPECT_GT(lazy_bottleneck.stats.search_rounds, 1);
  // The same query again reuses what the first one checked (its batches may still check a few
  // edges its own search order reaches).
  const MergeResult again = lazy.Query({.type = MeasureType::kBottleneckClearance});
  EXPECT_LT(again.stats.edges_checked, lazy_bottleneck.stats.edges_checked);
  EXPECT_EQ(again.stats.node_clearances, 0);
  EXPECT_NEAR(again.objective, lazy_bottleneck.objective, 1e-12);
}

// The post-optimization adds nodes and edges to the query's own overlay of the H-Graph, which
// goes with the query: an eager requery afterwards profiles the H-Graph's own edges and answers
// as a fresh eager merge under its measure does.
TEST_F(MergeTest, EagerRequeryAfterPostOptimizationSeesTheHGraphAsBuilt) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = CirclePaths();
  const double safest_input = SafestInputClearance(planner, inputs);
  ASSERT_GT(safest_input, 0);
  for (const MeasureSpec& first :
       {MeasureSpec{.type = MeasureType::kLength},
        MeasureSpec{.type = MeasureType::kSafeLength, .safety = 0.5 * safest_input}}) {
    SCOPED_TRACE(MeasureTypeName(first.type));
    HybridizationSession session(
        planner, MergeRequest{.paths = inputs,
                              .options = {.candidates = {.variant = Variant::kAllPairs},
                                          .evaluation = Evaluation::kEager}});
    const int edges_before = session.graph().num_edges();
    const MergeResult merged = session.Query(first);
    ASSERT_GT(merged.stats.shortcuts, 0);
    EXPECT_EQ(session.graph().num_edges(), edges_before);
    const MergeResult widest = session.Query({.type = MeasureType::kBottleneckClearance});
    const MergeResult fresh =
        Merge(planner, MergeRequest{.paths = inputs,
                                    .measure = {.type = MeasureType::kBottleneckClearance},
                                    .options = {.candidates = {.variant = Variant::kAllPairs},
                                                .evaluation = Evaluation::kEager}});
    EXPECT_EQ(widest.path.waypoints, fresh.path.waypoints);
    const InputReport check = CheckPaths(planner, {.paths = {widest.path}}).paths.at(0);
    EXPECT_TRUE(check.valid && check.certified);
    EXPECT_TRUE(widest.quality.has_clearance);
    EXPECT_NEAR(widest.objective, -widest.quality.min_clearance, 1e-12);
    EXPECT_GE(widest.quality.min_clearance,
              merged.quality.has_clearance ? merged.quality.min_clearance - 1e-12 : 0.0);
  }
}

// Stats derived from the H-Graph, not kept beside it: an eager AddPaths of a path through the
// discs reports its invalid input edge in the next query (the count stayed at the build's), and
// that query reports the AddPaths' checks with its own (they were dropped).
TEST_F(MergeTest, AddPathsWorkAndInvalidInputsReachTheNextQuerysStats) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = CirclePaths();
  HybridizationSession session(
      planner, MergeRequest{.paths = inputs,
                            .options = {.evaluation = Evaluation::kEager, .optimize_ms = 0}});
  const MergeResult before = session.Query({});
  EXPECT_EQ(before.stats.input_edges_invalid, 0);
  const MergeResult again = session.Query({});
  EXPECT_EQ(again.stats.edges_checked, 0);
  const InputPath straight{.name = "straight",
                           .waypoints = {inputs[0].waypoints.front(), inputs[0].waypoints.back()}};
  // Start and goal only: no new node, one input edge and the bridges its alignment with the
  // stored inputs adds, all of which the eager AddPaths checks.
  const int64_t bridges = session.AddPaths({straight});
  const MergeResult after = session.Query({});
  EXPECT_EQ(after.stats.input_edges_invalid, 1);
  EXPECT_EQ(after.stats.candidate_edges, before.stats.candidate_edges + bridges);
  EXPECT_GE(after.stats.edges_checked, 1 + bridges);  // and the path its query certifies
  EXPECT_GT(after.stats.collision_checks, 0);
  // Reported once: the query after it did no work of its own.
  const MergeResult later = session.Query({});
  EXPECT_EQ(later.stats.edges_checked, 0);
  EXPECT_EQ(later.stats.collision_checks, 0);
  EXPECT_EQ(later.stats.input_edges_invalid, 1);
}

TEST_F(MergeTest, InvalidInputEdgeIsReportedAndNotUsed) {
  const LocalPlanner planner = MakePlanner();
  std::vector<InputPath> inputs = CirclePaths();
  // Straight through the discs from start to goal.
  inputs.push_back(InputPath{
      .name = "straight", .waypoints = {inputs[0].waypoints.front(), inputs[0].waypoints.back()}});
  const MergeResult r =
      Merge(planner, MergeRequest{.paths = inputs, .options = {.report_inputs = true}});
  ASSERT_EQ(r.inputs.size(), 3u);
  EXPECT_FALSE(r.inputs[2].valid);
  EXPECT_EQ(r.inputs[2].invalid_edge, 0);
  EXPECT_EQ(r.stats.input_edges_invalid, 1);
  ExpectValid(planner, r.path);
  EXPECT_GT(r.path.waypoints.size(), 2u);
}

TEST_F(MergeTest, SubdividedInputsMergeNoWorseAndNameTheInputsOwnEdges) {
  const LocalPlanner planner = MakePlanner();
  std::vector<InputPath> inputs = PerturbedPaths(planner, 7, 3);
  const InputPath straight{.name = "straight",
                           .waypoints = {inputs[0].waypoints.front(), inputs[0].waypoints.back()}};
  inputs.push_back(straight);  // through the discs: its only edge is invalid
  for (const MeasureSpec& measure : {MeasureSpec{.type = MeasureType::kLength},
                                     MeasureSpec{.type = MeasureType::kInverseClearance, .k = 3}}) {
    SCOPED_TRACE(MeasureTypeName(measure.type));
    const MergeOptions plain_options{
        .candidates = {.variant = Variant::kAllPairs}, .report_inputs = true, .optimize_ms = 0};
    MergeOptions dense_options = plain_options;
    dense_options.max_node_spacing = 3.0;
    const MergeResult plain =
        Merge(planner, MergeRequest{.paths = inputs, .measure = measure, .options = plain_options});
    const MergeResult dense =
        Merge(planner, MergeRequest{.paths = inputs, .measure = measure, .options = dense_options});
    EXPECT_GT(dense.stats.nodes, plain.stats.nodes);
    ExpectValid(planner, dense.path);
    EXPECT_TRUE(dense.path.waypoints.front().isApprox(inputs[0].waypoints.front()));
    EXPECT_TRUE(dense.path.waypoints.back().isApprox(inputs[0].waypoints.back()));
    if (measure.type == MeasureType::kLength) {
      // All-pairs on the subdivided graph still holds every pair of the plain one.
      EXPECT_LE(dense.quality.length, plain.quality.length + 1e-9);
    }
    EXPECT_LE(dense.objective, dense.best_input_objective + 1e-9);
    // Inputs are reported as the inputs, not as their subdivided edges.
    ASSERT_EQ(dense.inputs.size(), 4u);
    for (size_t i = 0; i < 3; ++i) {
      EXPECT_TRUE(dense.inputs[i].valid);
      EXPECT_EQ(dense.inputs[i].waypoints, static_cast<int>(inputs[i].waypoints.size()));
      EXPECT_NEAR(dense.inputs[i].quality.length, plain.inputs[i].quality.length, 1e-9);
    }
    EXPECT_FALSE(dense.inputs[3].valid);
    EXPECT_EQ(dense.inputs[3].invalid_edge, 0);
    EXPECT_NE(dense.inputs[3].invalid_reason.find("edge 0 -> 1"), std::string::npos);
    // Where each output waypoint lies on its input.
    ASSERT_EQ(dense.source_fraction.size(), dense.path.waypoints.size());
    for (size_t j = 0; j < dense.path.waypoints.size(); ++j) {
      const InputPath& source = inputs[dense.source_path[j]];
      const int index = dense.source_index[j];
      const double t = dense.source_fraction[j];
      const Config at = t == 0 ? source.waypoints[index]
                               : planner.space().Interpolate(source.waypoints[index],
                                                             source.waypoints[index + 1], t);
      EXPECT_TRUE(dense.path.waypoints[j].isApprox(at)) << "waypoint " << j;
    }
  }
}

TEST_F(MergeTest, PostOptimizationShortensWithCertifiedMotionsAndStreamsEachImprovement) {
  const LocalPlanner planner = MakePlanner();
  std::mutex mu;
  std::vector<double> improvements;
  MergeRequest request{.paths = CirclePaths()};
  request.progress = [&](const Progress& p) {
    std::lock_guard<std::mutex> lock(mu);
    EXPECT_EQ(p.path, nullptr) << "paths only with progress_paths";
    if (p.phase == "optimize") {
      EXPECT_FALSE(std::isnan(p.objective));
      EXPECT_EQ(p.done == 0, improvements.empty()) << "round 0 first, and only then";
      improvements.push_back(p.objective);
    } else {
      EXPECT_TRUE(std::isnan(p.objective)) << p.phase;
    }
  };
  const MergeResult r = Merge(planner, request);
  MergeRequest off = request;
  off.progress = {};
  off.options.optimize_ms = 0;
  const MergeResult plain = Merge(planner, off);
  EXPECT_DOUBLE_EQ(r.hgraph_objective, plain.objective);
  EXPECT_DOUBLE_EQ(plain.hgraph_objective, plain.objective);
  EXPECT_EQ(plain.stats.optimize_rounds, 0);
  // Circle paths leave room between the discs: shortcuts shorten the H-Graph optimum.
  EXPECT_LT(r.objective, r.hgraph_objective * (1 - 1e-3));
  EXPECT_GT(r.stats.shortcuts, 0);
  // The H-Graph optimum, then each improvement.
  ASSERT_GE(improvements.size(), 2u);
  EXPECT_DOUBLE_EQ(improvements.front(), r.hgraph_objective);
  for (size_t i = 1; i < improvements.size(); ++i) EXPECT_LT(improvements[i], improvements[i - 1]);
  EXPECT_LE(r.objective, improvements.back() + 1e-9);
  EXPECT_TRUE(r.path.waypoints.front().isApprox(CirclePaths()[0].waypoints.front()));
  EXPECT_TRUE(r.path.waypoints.back().isApprox(CirclePaths()[0].waypoints.back()));
  // The merged path passes the certified check, as `hgraph check` runs it.
  const PathCheckResult check = CheckPaths(planner, PathCheckRequest{.paths = {r.path}});
  ASSERT_EQ(check.paths.size(), 1u);
  EXPECT_TRUE(check.paths[0].valid);
  EXPECT_TRUE(check.paths[0].certified);
  EXPECT_NEAR(check.paths[0].quality.length, r.quality.length, 1e-9 * r.quality.length);
  // Points the post-optimization made: on no input, or inside an input's edge.
  bool made = false;
  for (size_t j = 0; j < r.source_path.size(); ++j) {
    made = made || r.source_path[j] < 0 || r.source_fraction[j] > 0;
  }
  EXPECT_TRUE(made);
}

// A query's optimize_until (the server's MergeOptions.optimize_to_deadline) is a budget in time
// that ends then: one already passed leaves the H-Graph's optimum and says so; a later one runs
// rounds, restarts included, until it comes (or the overlay's growth limit), and its answer is
// certified. Only what stopped the rounds is checked, never how long they took.
TEST_F(MergeTest, OptimizeUntilEndsThePostOptimizationAndSaysSo) {
  const LocalPlanner planner = MakePlanner();
  HybridizationSession session(planner, MergeRequest{.paths = CirclePaths()});
  const auto now = std::chrono::steady_clock::now();
  const MergeResult passed = session.Query({}, {}, {}, std::nullopt, now);
  EXPECT_EQ(passed.stats.optimize_stop, OptimizeStop::kDeadline);
  EXPECT_EQ(passed.stats.optimize_rounds, 0);
  EXPECT_DOUBLE_EQ(passed.objective, passed.hgraph_objective);
  const MergeResult spent = session.Query(
      {}, {}, {}, std::nullopt, std::chrono::steady_clock::now() + std::chrono::seconds(1));
  EXPECT_TRUE(spent.stats.optimize_stop == OptimizeStop::kDeadline ||
              spent.stats.optimize_stop == OptimizeStop::kGrowth)
      << OptimizeStopName(spent.stats.optimize_stop);
  EXPECT_GT(spent.stats.optimize_rounds, 0);
  EXPECT_LE(spent.objective, spent.hgraph_objective);
  const PathCheckResult check = CheckPaths(planner, PathCheckRequest{.paths = {spent.path}});
  EXPECT_TRUE(check.paths.at(0).valid && check.paths.at(0).certified);
  // With optimize_ms too, the shorter budget holds and names the stop: here optimize_ms.
  HybridizationSession timed(planner,
                             MergeRequest{.paths = CirclePaths(), .options = {.optimize_ms = 1}});
  const MergeResult shorter = timed.Query({}, {}, {}, std::nullopt,
                                          std::chrono::steady_clock::now() + std::chrono::hours(1));
  EXPECT_EQ(shorter.stats.optimize_stop, OptimizeStop::kTime);
  EXPECT_STREQ(OptimizeStopName(OptimizeStop::kDeadline), "deadline");
}

TEST_F(MergeTest, AddPathsGrowsTheHGraphLikeMergingEverythingAtOnce) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = PerturbedPaths(planner, 7, 3);
  for (const Variant variant : {Variant::kAllPairs, Variant::kNeighborhood, Variant::kKNearest,
                                Variant::kEditDistance, Variant::kEditDistanceNeighborhood}) {
    SCOPED_TRACE(VariantName(variant));
    const MergeOptions options{.candidates = {.variant = variant, .phi = 3}, .optimize_ms = 0};
    HybridizationSession grown(planner, MergeRequest{.paths = {inputs[0]}, .options = options});
    const MergeResult alone = grown.Query({});
    EXPECT_GE(grown.AddPaths({inputs[1], inputs[2]}), 0);
    const MergeResult after = grown.Query({});
    // At once, with the parameters the first build resolved (AddPaths keeps them).
    MergeOptions at_once = options;
    at_once.candidates.radius = alone.stats.radius;
    at_once.candidates.gap_init = alone.stats.gap_init;
    at_once.candidates.gap_extend = alone.stats.gap_extend;
    const MergeResult together = Merge(planner, MergeRequest{.paths = inputs, .options = at_once});
    ASSERT_EQ(after.inputs.size(), 3u);
    EXPECT_EQ(after.inputs[2].name, inputs[2].name);
    EXPECT_EQ(after.stats.nodes, together.stats.nodes);
    EXPECT_LE(after.objective, alone.objective + 1e-9);
    if (variant == Variant::kKNearest) {
      // The pairs of old nodes that new ones push out of the k nearest stay: a superset.
      EXPECT_GE(after.stats.candidate_edges, together.stats.candidate_edges);
      EXPECT_LE(after.objective, together.objective + 1e-9 * together.objective);
    } else {
      EXPECT_EQ(after.stats.candidate_edges, together.stats.candidate_edges);
      EXPECT_EQ(after.stats.alignments, together.stats.alignments);
      EXPECT_NEAR(after.objective, together.objective, 1e-9 * together.objective);
    }
    // What the first query checked is not checked again.
    EXPECT_GT(after.stats.edges_reused, 0);
  }
  const MergeOptions options{.candidates = {.variant = Variant::kAllPairs}, .optimize_ms = 0};
  HybridizationSession grown(planner, MergeRequest{.paths = {inputs[0]}, .options = options});
  grown.AddPaths({inputs[1]});
  const MergeResult after = grown.Query({});
  // A path that does not share the start is refused with its field named, and the H-Graph
  // is unchanged.
  InputPath stray = inputs[1];
  stray.waypoints.front() += Eigen::Vector2d(1.0, 0.0);
  try {
    grown.AddPaths({inputs[2], stray});
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "paths[1].waypoints[0]");
  }
  EXPECT_EQ(grown.Query({}).stats.nodes, after.stats.nodes);
}

TEST_F(MergeTest, CancelStopsTheMerge) {
  const LocalPlanner planner = MakePlanner();
  MergeRequest request{
      .paths = CirclePaths(),
      .options = {.candidates = {.variant = Variant::kAllPairs}, .evaluation = Evaluation::kEager}};
  request.cancel.Cancel();
  try {
    Merge(planner, request);
    FAIL() << "expected cancellation";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled);
  }
}

TEST_F(MergeTest, ProgressReachesTheTotal) {
  const LocalPlanner planner = MakePlanner();
  std::mutex mu;
  std::map<std::string, std::pair<int64_t, int64_t>> last;
  MergeRequest request{.paths = CirclePaths(),
                       .options = {.candidates = {.variant = Variant::kAllPairs},
                                   .evaluation = Evaluation::kEager,
                                   .optimize_ms = 0,
                                   .threads = 2}};
  request.progress = [&](const Progress& p) {
    std::lock_guard<std::mutex> lock(mu);
    auto& entry = last[p.phase];
    entry.first = std::max(entry.first, p.done);
    entry.second = p.total;
  };
  const MergeResult r = Merge(planner, request);
  ASSERT_TRUE(last.count("check"));
  EXPECT_EQ(last["check"].first, last["check"].second);
  EXPECT_EQ(last["check"].second, r.stats.candidate_edges);
}

TEST_F(MergeTest, ThreadCountDoesNotChangeTheResult) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = PerturbedPaths(planner, 9, 3);
  const MergeResult one = Merge(planner, MergeRequest{.paths = inputs, .options = {.threads = 1}});
  const MergeResult two = Merge(planner, MergeRequest{.paths = inputs, .options = {.threads = 2}});
  EXPECT_DOUBLE_EQ(one.quality.length, two.quality.length);
  EXPECT_EQ(one.path.waypoints, two.path.waypoints);
  EXPECT_EQ(one.stats.edges_valid, two.stats.edges_valid);
  // The same motions are checked; how many samples a check shared by two threads takes past its
  // answer (EdgeCheckRequest::threads) depends on their timing.
  EXPECT_EQ(one.stats.edges_checked, two.stats.edges_checked);
}

}  // namespace
}  // namespace hgraph

namespace hgraph {
namespace {

TEST_F(MergeTest, StatsAreConsistent) {
  const LocalPlanner planner = MakePlanner();
  for (Variant variant : {Variant::kAllPairs, Variant::kEditDistance}) {
    const MergeResult r =
        Merge(planner, MergeRequest{.paths = CirclePaths(),
                                    .options = {.candidates = {.variant = variant},
                                                .evaluation = Evaluation::kEager,
                                                .optimize_ms = 0}});
    EXPECT_GE(r.stats.edges_checked, r.stats.input_edges + r.stats.candidate_edges);
    EXPECT_LE(r.stats.edges_valid, r.stats.input_edges + r.stats.candidate_edges);
    // The repeated waypoint of the first OMPL path appears once in the output.
    for (size_t j = 1; j < r.path.waypoints.size(); ++j) {
      EXPECT_GT((r.path.waypoints[j] - r.path.waypoints[j - 1]).norm(), 0);
    }
  }
}

}  // namespace
}  // namespace hgraph

namespace hgraph {
namespace {

// What a client compares between two answers: the path, the objective, and where each waypoint
// came from. (A length query's quality also reports the clearance profiles an earlier query
// left on its path, PathQuality::has_clearance: more of the same path known, not another one.)
void ExpectSameAnswer(const MergeResult& a, const MergeResult& b) {
  EXPECT_EQ(a.path.waypoints, b.path.waypoints);
  EXPECT_EQ(a.objective, b.objective);
  EXPECT_EQ(a.quality.length, b.quality.length);
  EXPECT_EQ(a.source_path, b.source_path);
  EXPECT_EQ(a.source_index, b.source_index);
  EXPECT_EQ(a.source_fraction, b.source_fraction);
}

// The four measures a stored H-Graph is asked, as the trust issue's sequence asks them.
std::vector<MeasureSpec> FourMeasures(double safety) {
  return {MeasureSpec{.type = MeasureType::kBottleneckClearance}, MeasureSpec{},
          MeasureSpec{.type = MeasureType::kInverseClearance, .k = 3},
          MeasureSpec{.type = MeasureType::kSafeLength, .safety = safety}};
}

// One answer per query: every answer of a stored H-Graph equals the first query of a fresh
// H-Graph built from the same inputs and options, whatever was asked of it before (bottleneck,
// length, bottleneck, length, ...: the length queries' post-optimization used to leave its
// shortcuts in the graph), lazily or eagerly. Circles (all-pairs, as the issue measured) and the
// two mesh problems (defaults).
void ExpectOneAnswerPerQuery(const LocalPlanner& planner, const std::vector<InputPath>& inputs,
                             const MergeOptions& base) {
  const std::vector<MeasureSpec> measures =
      FourMeasures(0.5 * SafestInputClearance(planner, inputs));
  for (Evaluation evaluation : {Evaluation::kLazy, Evaluation::kEager}) {
    SCOPED_TRACE(EvaluationName(evaluation));
    MergeOptions options = base;
    options.evaluation = evaluation;
    std::vector<MergeResult> fresh;
    for (const MeasureSpec& m : measures) {
      fresh.push_back(
          Merge(planner, MergeRequest{.paths = inputs, .measure = m, .options = options}));
    }
    HybridizationSession stored(
        planner, MergeRequest{.paths = inputs,
                              .measure = {.type = MeasureType::kInverseClearance, .k = 3},
                              .options = options});
    const int nodes = stored.graph().num_nodes();
    const int edges = stored.graph().num_edges();
    for (int m : {0, 1, 0, 1, 2, 3, 1, 2, 0, 3}) {
      SCOPED_TRACE(MeasureTypeName(measures[m].type));
      const MergeResult r = stored.Query(measures[m]);
      ExpectSameAnswer(r, fresh[m]);
      // What a query leaves in the H-Graph is check reports, never nodes or edges.
      EXPECT_EQ(stored.graph().num_nodes(), nodes);
      EXPECT_EQ(stored.graph().num_edges(), edges);
    }
  }
}

TEST_F(MergeTest, AStoredHGraphGivesOneAnswerPerQuery) {
  const LocalPlanner planner = MakePlanner();
  ExpectOneAnswerPerQuery(planner, PerturbedPaths(planner, 5, 3),
                          MergeOptions{.candidates = {.variant = Variant::kAllPairs}});
}

TEST(MergeMeshTest, AStoredHGraphGivesOneAnswerPerQuery) {
  ForMeshProblems([](const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
    ExpectOneAnswerPerQuery(planner, inputs, MergeOptions{});
  });
}

// The automatic post-optimization stops by rounds, never by the clock: the same answer with one
// thread or two, and the result says what stopped it.
TEST_F(MergeTest, PostOptimizationIsTheSameWithAnyThreadCount) {
  const LocalPlanner planner = MakePlanner();
  const std::vector<InputPath> inputs = PerturbedPaths(planner, 11, 3);
  for (const MergeOptions& options :
       {MergeOptions{}, MergeOptions{.partial_shortcuts = true, .optimize_restarts = 2}}) {
    std::vector<MergeResult> runs;
    for (int threads : {1, 2}) {
      MergeOptions o = options;
      o.threads = threads;
      runs.push_back(Merge(planner, MergeRequest{.paths = inputs, .options = o}));
    }
    ExpectSameAnswer(runs[0], runs[1]);
    EXPECT_GT(runs[0].stats.optimize_rounds, 0);
    EXPECT_EQ(runs[0].stats.optimize_rounds, runs[1].stats.optimize_rounds);
    EXPECT_NE(runs[0].stats.optimize_stop, OptimizeStop::kTime);
    EXPECT_NE(runs[0].stats.optimize_stop, OptimizeStop::kOff);
  }
  const MergeResult off =
      Merge(planner, MergeRequest{.paths = inputs, .options = {.optimize_ms = 0}});
  EXPECT_EQ(off.stats.optimize_stop, OptimizeStop::kOff);
}

// Where each merged waypoint comes from, after the post-optimization too: a waypoint that names
// an input lies on that input's edge (source_index, source_index + 1) at source_fraction; the
// others are ends of shortcuts on no input. Returns how many lie inside an input's edge.
int ExpectWaypointsWhereTheySay(const Space& space, const std::vector<InputPath>& inputs,
                                const MergeResult& r) {
  EXPECT_EQ(r.source_path.size(), r.path.waypoints.size());
  EXPECT_EQ(r.source_index.size(), r.path.waypoints.size());
  EXPECT_EQ(r.source_fraction.size(), r.path.waypoints.size());
  int inside = 0;
  for (size_t j = 0; j < r.path.waypoints.size() && j < r.source_path.size(); ++j) {
    SCOPED_TRACE("waypoint " + std::to_string(j));
    const int p = r.source_path[j];
    if (p < 0) {
      EXPECT_EQ(r.source_index[j], -1);
      continue;
    }
    EXPECT_LT(p, static_cast<int>(inputs.size()));
    if (p >= static_cast<int>(inputs.size())) continue;
    const std::vector<Config>& w = inputs[p].waypoints;
    const int i = r.source_index[j];
    const double t = r.source_fraction[j];
    EXPECT_TRUE(i >= 0 && i < static_cast<int>(w.size()) && t >= 0 && t < 1) << i << " " << t;
    if (!(i >= 0 && i < static_cast<int>(w.size()))) continue;
    const Config at = t == 0 ? w[i] : space.Interpolate(w[i], w[i + 1], t);
    EXPECT_LT(space.Distance(at, r.path.waypoints[j]), 1e-9);
    if (t > 0) ++inside;
  }
  return inside;
}

TEST_F(MergeTest, EveryMergedWaypointNamesWhereItLies) {
  const LocalPlanner planner = MakePlanner();
  for (uint64_t seed : {3, 5, 9}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const std::vector<InputPath> inputs = PerturbedPaths(planner, seed, 3);
    const MergeResult r = Merge(planner, MergeRequest{.paths = inputs});
    ASSERT_GT(r.stats.shortcuts, 0);
    ExpectWaypointsWhereTheySay(planner.space(), inputs, r);
  }
}

// On the mesh problems too, with partial shortcuts (whose points lie on no input) and without.
TEST(MergeMeshTest, EveryMergedWaypointNamesWhereItLies) {
  ForMeshProblems([&](const LocalPlanner& planner, const std::vector<InputPath>& inputs) {
    for (const MergeOptions& options : {MergeOptions{}, MergeOptions{.partial_shortcuts = true},
                                        MergeOptions{.max_node_spacing = 0.5}}) {
      const MergeResult r = Merge(planner, MergeRequest{.paths = inputs, .options = options});
      EXPECT_GT(r.stats.shortcuts, 0);
      ExpectWaypointsWhereTheySay(planner.space(), inputs, r);
    }
  });
}

}  // namespace
}  // namespace hgraph
