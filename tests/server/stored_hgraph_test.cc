// Re-queries of a stored H-Graph (QueryStored, what Requery runs on a worker).
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <memory>

#include "core/collision/collision_world.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "server/call_support.h"
#include "tests/unit/test_scenes.h"

namespace hgraph::server {
namespace {

using Stored = PathMergerService::StoredHGraph;

std::shared_ptr<Stored> MergedCircles() {
  auto stored = std::make_shared<Stored>();
  stored->scene.world = std::make_shared<const CollisionWorld>(testing::CirclesScene());
  stored->planner =
      std::make_unique<LocalPlanner>(stored->scene.world, LocalPlannerOptions{.resolution = 0.01});
  MergeRequest request{.paths = testing::CirclePaths(), .measure = MeasureSpec{}};
  request.options.optimize_ms = 0;
  stored->session = std::make_unique<HybridizationSession>(*stored->planner, request);
  stored->session->Query(request.measure);
  return stored;
}

MeasureSpec Clearance() { return MeasureSpec{.type = MeasureType::kInverseClearance, .k = 2}; }

// The H-Graph's mutex is free while a query searches: another call may take it (to start its
// own query, or to be evicted) without waiting for this one.
TEST(QueryStored, DoesNotHoldTheHGraphWhileItSearches) {
  const std::shared_ptr<Stored> stored = MergedCircles();
  int events = 0;
  int locked_out = 0;
  const ProgressCallback progress = [&](const Progress&) {
    ++events;
    if (stored->mutex.try_lock()) {
      stored->mutex.unlock();
    } else {
      ++locked_out;
    }
  };
  const MergeResult result = QueryStored(*stored, Clearance(), progress, CancelToken());
  EXPECT_GT(result.quality.length, 0);
  ASSERT_GT(events, 0);
  EXPECT_EQ(locked_out, 0) << "the query held the H-Graph's mutex";
}

// What a query checked stays in the stored H-Graph: the same measure again checks nothing new.
TEST(QueryStored, KeepsTheChecksAQueryMade) {
  const std::shared_ptr<Stored> stored = MergedCircles();
  const MergeResult first = QueryStored(*stored, Clearance(), {}, CancelToken());
  EXPECT_GT(first.stats.edges_checked, 0);
  const MergeResult again = QueryStored(*stored, Clearance(), {}, CancelToken());
  EXPECT_EQ(again.stats.edges_checked, 0);
  EXPECT_GT(again.stats.edges_reused, 0);
  EXPECT_EQ(again.path.waypoints, first.path.waypoints);
}

// Overlapping queries of one H-Graph each get their own, correct answer.
TEST(QueryStored, OverlappingQueriesAnswerAsQueriesInTurn) {
  const std::shared_ptr<Stored> reference = MergedCircles();
  const MergeResult length = QueryStored(*reference, MeasureSpec{}, {}, CancelToken());
  const MergeResult clearance = QueryStored(*reference, Clearance(), {}, CancelToken());

  const std::shared_ptr<Stored> stored = MergedCircles();
  auto a = std::async(std::launch::async,
                      [&] { return QueryStored(*stored, MeasureSpec{}, {}, CancelToken()); });
  auto b = std::async(std::launch::async,
                      [&] { return QueryStored(*stored, Clearance(), {}, CancelToken()); });
  EXPECT_EQ(a.get().path.waypoints, length.path.waypoints);
  EXPECT_EQ(b.get().path.waypoints, clearance.path.waypoints);
}

}  // namespace
}  // namespace hgraph::server
