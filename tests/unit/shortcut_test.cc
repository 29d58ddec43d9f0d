// Certified partial shortcuts (core/merge/shortcut.h) on the OMPL circles scene: the result is
// shorter, keeps the endpoints, is certified edge by edge, does not depend on the thread count,
// and reuses the motions its caller already knows instead of checking them again. On the rod
// through the holed wall (SE(3)): shortcuts that move one part of the configuration alone.
#include "core/merge/shortcut.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/common/progress.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"
#include "tests/unit/test_scenes.h"

namespace hgraph {
namespace {

using testing::CirclePaths;
using testing::CirclesScene;

double Length(const Space& space, const InputPath& path) {
  double length = 0;
  for (size_t j = 0; j + 1 < path.waypoints.size(); ++j) {
    length += space.Distance(path.waypoints[j], path.waypoints[j + 1]);
  }
  return length;
}

// The path's own motions, certified (ShortcutRequest::edges); each must be valid.
std::vector<EdgeReport> CertifiedEdges(const LocalPlanner& planner, const InputPath& path) {
  std::vector<EdgeReport> edges;
  for (size_t j = 0; j + 1 < path.waypoints.size(); ++j) {
    edges.push_back(planner.CheckEdge({.from = &path.waypoints[j],
                                       .to = &path.waypoints[j + 1],
                                       .proof = EdgeProof::kCertificate}));
    EXPECT_EQ(edges.back().state, EdgeState::kValid) << path.name << " edge " << j;
  }
  return edges;
}

class ShortcutTest : public ::testing::Test {
 protected:
  ShortcutTest()
      : planner_(std::make_shared<CollisionWorld>(CirclesScene())), path_(CirclePaths()[0]) {}

  // The input path with an id per waypoint (its index).
  ShortcutRequest Request() const {
    ShortcutRequest request{.path = path_, .seed = 7};
    for (size_t j = 0; j < path_.waypoints.size(); ++j) {
      request.ids.push_back(static_cast<int>(j));
    }
    return request;
  }

  // The path passes the certified check, as `hgraph check` runs it.
  void ExpectCertified(const InputPath& path) const {
    const PathCheckResult check = CheckPaths(planner_, PathCheckRequest{.paths = {path}});
    ASSERT_EQ(check.paths.size(), 1u);
    EXPECT_TRUE(check.paths[0].valid);
    EXPECT_TRUE(check.paths[0].certified);
  }

  LocalPlanner planner_;
  InputPath path_;
};

TEST_F(ShortcutTest, ShortensKeepsTheEndpointsAndEveryEdgeIsCertified) {
  const ShortcutResult r = ShortcutCertified(planner_, Request());
  const Space& space = planner_.space();
  ASSERT_GT(r.accepted, 0);
  EXPECT_LT(Length(space, r.path), Length(space, path_) * (1 - 1e-3));
  EXPECT_TRUE(r.path.waypoints.front().isApprox(path_.waypoints.front()));
  EXPECT_TRUE(r.path.waypoints.back().isApprox(path_.waypoints.back()));
  ASSERT_EQ(r.edges.size() + 1, r.path.waypoints.size());
  ASSERT_EQ(r.ids.size(), r.path.waypoints.size());
  for (size_t j = 0; j < r.edges.size(); ++j) {
    EXPECT_EQ(r.edges[j].state, EdgeState::kValid) << "edge " << j;
    EXPECT_NEAR(r.edges[j].length, space.Distance(r.path.waypoints[j], r.path.waypoints[j + 1]),
                1e-9);
    // Kept input waypoints carry their id, points the shortcuts made carry -1.
    if (r.ids[j] >= 0) {
      EXPECT_TRUE(r.path.waypoints[j].isApprox(path_.waypoints[r.ids[j]]));
    }
  }
  ExpectCertified(r.path);
}

// A budget's end (ShortcutRequest::until) with a token whose deadline is the same end: where it
// has passed, the shortening returns the path as it came, every edge its own, without throwing;
// the token's deadline without `until` (the caller's own stop) throws.
TEST_F(ShortcutTest, ABudgetsEndReturnsWhatWasTakenAndAStopThrows) {
  const auto passed = std::chrono::steady_clock::now() - std::chrono::milliseconds(1);
  const CancelToken budget = CancelToken().WithDeadline(passed);
  ShortcutRequest request = Request();
  request.until = passed;
  const ShortcutResult r = ShortcutCertified(planner_, request, budget);
  EXPECT_EQ(r.accepted, 0);
  EXPECT_EQ(r.path.waypoints, path_.waypoints);
  EXPECT_EQ(r.edges.size() + 1, path_.waypoints.size());
  try {
    ShortcutCertified(planner_, Request(), budget);
    ADD_FAILURE() << "a passed deadline without `until` did not throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kDeadlineExceeded);
  }
}

// Lazy shortcuts (ShortcutRequest::lazy) take motions valid at their samples: no distance query
// at all, where the certified ones make some; a shorter path with the endpoints, every edge valid
// when checked again at its samples, the new ones uncertified (the caller certifies them).
TEST_F(ShortcutTest, LazyShortcutsCheckOnlyTheSamples) {
  const Space& space = planner_.space();
  const int64_t queries_before = planner_.total_distance_queries();
  ShortcutCertified(planner_, Request());
  const int64_t certified_queries = planner_.total_distance_queries() - queries_before;
  EXPECT_GT(certified_queries, 0);
  ShortcutRequest request = Request();
  request.lazy = true;
  const int64_t checks_before = planner_.total_collision_checks();
  const ShortcutResult r = ShortcutCertified(planner_, request);
  EXPECT_EQ(planner_.total_distance_queries() - queries_before, certified_queries);
  EXPECT_GT(planner_.total_collision_checks(), checks_before);
  ASSERT_GT(r.accepted, 0);
  EXPECT_LT(Length(space, r.path), Length(space, path_) * (1 - 1e-3));
  EXPECT_TRUE(r.path.waypoints.front().isApprox(path_.waypoints.front()));
  EXPECT_TRUE(r.path.waypoints.back().isApprox(path_.waypoints.back()));
  ASSERT_EQ(r.edges.size() + 1, r.path.waypoints.size());
  int uncertified = 0;
  for (size_t j = 0; j < r.edges.size(); ++j) {
    const EdgeReport sampled = planner_.CheckEdge({.from = &r.path.waypoints[j],
                                                   .to = &r.path.waypoints[j + 1],
                                                   .proof = EdgeProof::kSamples});
    EXPECT_EQ(sampled.state, EdgeState::kValid) << "edge " << j;
    uncertified += r.edges[j].state == EdgeState::kValid && !r.edges[j].certified;
  }
  EXPECT_GT(uncertified, 0);
}

TEST_F(ShortcutTest, CornerCutsReplaceCornersByCertifiedMotions) {
  ShortcutRequest request = Request();
  request.corners_only = true;
  // The input's own motions, certified: the pieces of them a cut leaves keep their verdict.
  request.edges = CertifiedEdges(planner_, path_);
  const ShortcutResult r = ShortcutCertified(planner_, request);
  const Space& space = planner_.space();
  ASSERT_GT(r.accepted, 0);
  EXPECT_LT(Length(space, r.path), Length(space, path_));
  // Nothing else happens: every waypoint is kept (with its id) or cut.
  const auto kept = std::count_if(r.ids.begin(), r.ids.end(), [](int id) { return id >= 0; });
  EXPECT_EQ(kept + r.accepted, static_cast<long>(path_.waypoints.size()));
  EXPECT_EQ(r.ids.front(), 0);
  EXPECT_EQ(r.ids.back(), static_cast<int>(path_.waypoints.size()) - 1);
  for (size_t j = 0; j < r.edges.size(); ++j) {
    EXPECT_EQ(r.edges[j].state, EdgeState::kValid) << "edge " << j;
    // The input repeats a waypoint (a zero-length edge it keeps); a cut makes none.
    if (r.ids[j] < 0 || r.ids[j + 1] < 0) {
      EXPECT_GT(r.edges[j].length, 0) << "edge " << j;
    }
  }
  ExpectCertified(r.path);
}

// Where the result's waypoints lie on the input (ShortcutRequest::sources): a kept waypoint keeps
// its source, a new point on one of the input's edges names that edge and its fraction (corner
// cuts put every new point there), and a point on a motion the shortcuts made names none.
TEST_F(ShortcutTest, NewPointsNameTheInputEdgeTheyLieOn) {
  const Space& space = planner_.space();
  for (const bool corners : {true, false}) {
    SCOPED_TRACE(corners ? "corner cuts" : "random shortcuts");
    ShortcutRequest request = Request();
    request.corners_only = corners;
    request.edges = CertifiedEdges(planner_, path_);
    for (size_t j = 0; j < path_.waypoints.size(); ++j) {
      request.sources.push_back(WaypointSource{.path = 4, .index = static_cast<int>(j)});
    }
    const ShortcutResult r = ShortcutCertified(planner_, request);
    ASSERT_GT(r.accepted, 0);
    ASSERT_EQ(r.sources.size(), r.path.waypoints.size());
    int inside = 0;
    for (size_t j = 0; j < r.path.waypoints.size(); ++j) {
      SCOPED_TRACE("waypoint " + std::to_string(j));
      const WaypointSource& source = r.sources[j];
      if (r.ids[j] >= 0) {
        EXPECT_EQ(source.index, r.ids[j]);
        EXPECT_EQ(source.t, 0);
        continue;
      }
      if (source.path < 0) continue;  // a shortcut's end on a motion that is not the input's
      EXPECT_EQ(source.path, 4);
      ASSERT_GE(source.index, 0);
      ASSERT_LT(source.index + 1, static_cast<int>(path_.waypoints.size()));
      EXPECT_GT(source.t, 0);
      EXPECT_LT(source.t, 1);
      const Config at = space.Interpolate(path_.waypoints[source.index],
                                          path_.waypoints[source.index + 1], source.t);
      EXPECT_LT(space.Distance(at, r.path.waypoints[j]), 1e-9);
      ++inside;
    }
    if (corners) {
      EXPECT_GT(inside, 0);
      // Every cut's points lie on the input's own edges.
      const auto made = std::count_if(r.ids.begin(), r.ids.end(), [](int id) { return id < 0; });
      EXPECT_EQ(inside, made);
    }
  }
  // Between two points on one input edge, and across its ends; none between two inputs.
  const WaypointSource a{.path = 1, .index = 2, .t = 0.5};
  EXPECT_EQ(SourceBetween(a, {.path = 1, .index = 3}, 0.5).t, 0.75);
  EXPECT_EQ(SourceBetween({.path = 1, .index = 3}, a, 0.5).t, 0.75);
  EXPECT_EQ(SourceBetween(a, {.path = 1, .index = 3}, 1.0).index, 3);
  EXPECT_EQ(SourceBetween(a, {.path = 1, .index = 2, .t = 0.1}, 0.5).t, 0.3);
  EXPECT_EQ(SourceBetween(a, {.path = 2, .index = 3}, 0.5).path, -1);
  EXPECT_EQ(SourceBetween(a, {.path = 1, .index = 4}, 0.5).path, -1);
}

TEST_F(ShortcutTest, TheThreadCountDoesNotChangeTheResult) {
  ShortcutRequest request = Request();
  request.threads = 1;
  const ShortcutResult one = ShortcutCertified(planner_, request);
  request.threads = 2;
  const ShortcutResult two = ShortcutCertified(planner_, request);
  ASSERT_EQ(one.path.waypoints.size(), two.path.waypoints.size());
  for (size_t j = 0; j < one.path.waypoints.size(); ++j) {
    EXPECT_EQ(one.path.waypoints[j], two.path.waypoints[j]) << "waypoint " << j;
  }
  EXPECT_EQ(one.ids, two.ids);
  EXPECT_EQ(one.accepted, two.accepted);
  EXPECT_EQ(one.edges_checked, two.edges_checked);
}

TEST_F(ShortcutTest, MotionsTheCallerKnowsAreNotCheckedAgain) {
  // Only the pass that drops waypoints: one random pair at most.
  ShortcutRequest request = Request();
  request.attempts = 1;
  const ShortcutResult plain = ShortcutCertified(planner_, request);
  // Every motion it checked between two waypoints with ids is handed back.
  ASSERT_FALSE(plain.id_checks.empty());
  EXPECT_GE(plain.edges_checked, static_cast<int64_t>(plain.id_checks.size()));
  for (const auto& [a, b, report] : plain.id_checks) {
    const EdgeReport again = planner_.CheckEdge(
        {.from = &path_.waypoints[a], .to = &path_.waypoints[b], .proof = EdgeProof::kCertificate});
    EXPECT_EQ(report.state, again.state) << a << "-" << b;
  }

  // The caller knows every such motion: none is checked again, and the verdicts it knows are
  // the ones taken.
  request.known = [&](int a, int b) -> const EdgeReport* {
    for (const auto& [ka, kb, report] : plain.id_checks) {
      if (ka == a && kb == b) return &report;
    }
    return nullptr;
  };
  const ShortcutResult reused = ShortcutCertified(planner_, request);
  EXPECT_TRUE(reused.id_checks.empty());
  EXPECT_EQ(reused.edges_checked,
            plain.edges_checked - static_cast<int64_t>(plain.id_checks.size()));
  EXPECT_EQ(reused.ids, plain.ids);

  // A caller that knows every motion between waypoints to be blocked: nothing is dropped.
  const EdgeReport blocked{.state = EdgeState::kInvalid};
  request.known = [&](int, int) { return &blocked; };
  const ShortcutResult none = ShortcutCertified(planner_, request);
  EXPECT_TRUE(none.id_checks.empty());
  EXPECT_LE(none.edges_checked, 1);
  EXPECT_LE(none.accepted, 1);
}

// Partial shortcuts on the rod through the holed wall (SE(3), mesh against mesh): a quarter of
// the random pairs, or all of them, move one part (the translation or the rotation) straight
// while the other keeps its motion. The result is shorter, keeps the endpoints, is certified,
// and some of its new waypoints keep one part of an input waypoint exactly and not the other:
// the interior points of a partial shortcut, which a straight shortcut never makes.
TEST(ShortcutMeshTest, PartialShortcutsMoveOnePartAndAreCertified) {
  const std::string scene =
      std::string(HGRAPH_SOURCE_DIR) + "/tests/bench/scenes/hole_wall/scene.json";
  const LocalPlanner planner(std::make_shared<CollisionWorld>(LoadSceneFile(scene)),
                             {.resolution = SceneResolution(ReadSceneFile(scene))});
  const Space& space = planner.space();
  const std::vector<Space::Part> parts = space.Parts();
  ASSERT_EQ(parts.size(), 2u);
  const std::vector<InputPath> inputs =
      LoadPathsFile(std::string(HGRAPH_TEST_DATA_DIR) + "/hole_wall/prm4_seed1.json", space);
  ASSERT_FALSE(inputs.empty());
  // Waypoints with one part of an input waypoint exactly, and the other part not.
  const auto half_kept = [&](const ShortcutResult& r) {
    int count = 0;
    for (size_t j = 0; j < r.path.waypoints.size(); ++j) {
      if (r.ids[j] >= 0) continue;
      const Config& p = r.path.waypoints[j];
      const bool one = std::any_of(inputs.begin(), inputs.end(), [&](const InputPath& input) {
        return std::any_of(input.waypoints.begin(), input.waypoints.end(), [&](const Config& w) {
          const auto same = [&](const Space::Part& part) {
            return p.segment(part.offset, part.size) == w.segment(part.offset, part.size);
          };
          return same(parts[0]) != same(parts[1]);
        });
      });
      count += one ? 1 : 0;
    }
    return count;
  };
  int plain_half_kept = 0;
  int partial_half_kept = 0;
  for (const InputPath& input : inputs) {
    SCOPED_TRACE(input.name);
    for (double partial : {0.0, 0.25, 1.0}) {
      ShortcutRequest request{.path = input, .seed = 3, .partial = partial};
      for (size_t j = 0; j < input.waypoints.size(); ++j) {
        request.ids.push_back(static_cast<int>(j));
      }
      // The input's own motions, certified, for the edges that no shortcut replaces.
      request.edges = CertifiedEdges(planner, input);
      const ShortcutResult r = ShortcutCertified(planner, request);
      double after = 0;
      ASSERT_EQ(r.edges.size() + 1, r.path.waypoints.size());
      for (size_t j = 0; j < r.edges.size(); ++j) {
        EXPECT_EQ(r.edges[j].state, EdgeState::kValid) << "edge " << j;
        EXPECT_NEAR(r.edges[j].length, space.Distance(r.path.waypoints[j], r.path.waypoints[j + 1]),
                    1e-9);
        after += r.edges[j].length;
      }
      EXPECT_LT(after, Length(space, input));
      EXPECT_TRUE(r.path.waypoints.front().isApprox(input.waypoints.front()));
      EXPECT_TRUE(r.path.waypoints.back().isApprox(input.waypoints.back()));
      const PathCheckResult check = CheckPaths(planner, PathCheckRequest{.paths = {r.path}});
      EXPECT_TRUE(check.paths.at(0).valid && check.paths.at(0).certified) << "partial " << partial;
      (partial == 0 ? plain_half_kept : partial_half_kept) += half_kept(r);
    }
  }
  EXPECT_EQ(plain_half_kept, 0);
  EXPECT_GT(partial_half_kept, 0);
}

}  // namespace
}  // namespace hgraph
