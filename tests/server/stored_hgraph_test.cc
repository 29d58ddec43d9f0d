// Re-queries of a stored H-Graph (QueryStored, what Requery runs on a worker).
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <latch>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "core/collision/collision_world.h"
#include "core/merge/merge.h"
#include "core/merge/path_check.h"
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
  // Progress comes from the worker threads, possibly at once: the callbacks take turns, so that
  // only the query itself could hold the H-Graph's mutex when one tries it.
  std::mutex turns;
  const ProgressCallback progress = [&](const Progress&) {
    const std::lock_guard turn(turns);
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
  // Both start together, so that they overlap rather than run in turn.
  std::latch start(2);
  auto a = std::async(std::launch::async, [&] {
    start.arrive_and_wait();
    return QueryStored(*stored, MeasureSpec{}, {}, CancelToken());
  });
  auto b = std::async(std::launch::async, [&] {
    start.arrive_and_wait();
    return QueryStored(*stored, Clearance(), {}, CancelToken());
  });
  EXPECT_EQ(a.get().path.waypoints, length.path.waypoints);
  EXPECT_EQ(b.get().path.waypoints, clearance.path.waypoints);
}

// A stored H-Graph as the trust issue measured it: all-pairs, merged under inverse clearance
// (k = 3), the post-optimization on (its length requeries' shortcuts used to stay in the graph).
std::shared_ptr<Stored> MergedForRequeries() {
  auto stored = std::make_shared<Stored>();
  stored->scene.world = std::make_shared<const CollisionWorld>(testing::CirclesScene());
  stored->planner =
      std::make_unique<LocalPlanner>(stored->scene.world, LocalPlannerOptions{.resolution = 0.01});
  MergeRequest request{.paths = testing::CirclePaths(),
                       .measure = MeasureSpec{.type = MeasureType::kInverseClearance, .k = 3}};
  request.options.candidates.variant = Variant::kAllPairs;
  stored->session = std::make_unique<HybridizationSession>(*stored->planner, request);
  stored->session->Query(request.measure);
  return stored;
}

std::vector<MeasureSpec> FourMeasures(const Stored& stored) {
  double safest = 0;
  for (const InputReport& r :
       CheckPaths(*stored.planner, {.paths = testing::CirclePaths()}).paths) {
    if (r.valid) safest = std::max(safest, r.quality.min_clearance);
  }
  return {MeasureSpec{.type = MeasureType::kBottleneckClearance}, MeasureSpec{},
          MeasureSpec{.type = MeasureType::kInverseClearance, .k = 3},
          MeasureSpec{.type = MeasureType::kSafeLength, .safety = 0.5 * safest}};
}

// Eight clients sending six requeries each over four measures to one stored H-Graph at once
// (released together) get the answers the same requeries get one at a time, in any order.
TEST(QueryStored, ConcurrentRequeriesAnswerAsSequentialOnes) {
  const std::shared_ptr<Stored> reference = MergedForRequeries();
  const std::vector<MeasureSpec> measures = FourMeasures(*reference);
  std::vector<MergeResult> sequential;
  for (const MeasureSpec& m : measures) {
    sequential.push_back(QueryStored(*reference, m, {}, CancelToken()));
  }
  // Asked again in another order, after the others: the same.
  for (int m : {3, 1, 0, 2}) {
    EXPECT_EQ(QueryStored(*reference, measures[m], {}, CancelToken()).path.waypoints,
              sequential[m].path.waypoints)
        << MeasureTypeName(measures[m].type);
  }

  const std::shared_ptr<Stored> stored = MergedForRequeries();
  constexpr int kClients = 8;
  constexpr int kRequeries = 6;
  std::latch start(kClients);
  std::vector<std::vector<std::pair<int, MergeResult>>> answers(kClients);
  std::vector<std::thread> clients;
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      start.arrive_and_wait();
      for (int i = 0; i < kRequeries; ++i) {
        const int m = (c + i) % static_cast<int>(measures.size());
        answers[c].emplace_back(m, QueryStored(*stored, measures[m], {}, CancelToken()));
      }
    });
  }
  for (std::thread& t : clients) t.join();
  for (int c = 0; c < kClients; ++c) {
    for (const auto& [m, r] : answers[c]) {
      SCOPED_TRACE("client " + std::to_string(c) + ", " + MeasureTypeName(measures[m].type));
      EXPECT_EQ(r.path.waypoints, sequential[m].path.waypoints);
      EXPECT_EQ(r.objective, sequential[m].objective);
      EXPECT_EQ(r.source_path, sequential[m].source_path);
    }
  }
}

}  // namespace
}  // namespace hgraph::server
