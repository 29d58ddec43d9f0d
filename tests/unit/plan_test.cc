// OMPL's planners and baselines on a real scene (the built-in maze), checked with our own local
// planner; OMPL's pipeline as shipped (its discrete motion validator) on a wall thinner than a
// step.
#include "core/plan/plan.h"

#include <gtest/gtest.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/SpaceInformation.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"
#include "core/plan/baselines.h"
#include "core/plan/ompl_bridge.h"

namespace hgraph {
namespace {

struct Fixture {
  std::shared_ptr<const Scene> scene;
  std::shared_ptr<const CollisionWorld> world;
  std::unique_ptr<LocalPlanner> planner;
  double resolution = 0;
};

Fixture LoadBuiltIn(const std::string& name) {
  const std::string file = std::string(HGRAPH_SOURCE_DIR) + "/scenes/" + name + "/scene.json";
  Fixture f;
  f.resolution = SceneResolution(ReadSceneFile(file));
  f.scene = LoadSceneFile(file);
  f.world = std::make_shared<const CollisionWorld>(f.scene);
  f.planner =
      std::make_unique<LocalPlanner>(f.world, LocalPlannerOptions{.resolution = f.resolution});
  return f;
}

PlanRequest MazeRequest(const Fixture& f, PlannerType planner, uint64_t seed) {
  return PlanRequest{.planner = planner,
                     .start = *f.scene->start,
                     .goal = *f.scene->goal,
                     .count = 2,
                     .time_s = 5.0,
                     .seed = seed,
                     .resolution = f.resolution};
}

// Every edge passes the local planner in the strict form a merge uses for its inputs.
void ExpectValid(const LocalPlanner& planner, const InputPath& path) {
  ASSERT_GE(path.waypoints.size(), 2u);
  for (size_t j = 0; j + 1 < path.waypoints.size(); ++j) {
    const EdgeReport r = planner.CheckEdge(
        {.from = &path.waypoints[j], .to = &path.waypoints[j + 1], .proof = EdgeProof::kProfile});
    EXPECT_EQ(r.state, EdgeState::kValid) << path.name << " edge " << j;
    EXPECT_TRUE(r.certified) << path.name << " edge " << j;
  }
}

double Length(const Space& space, const InputPath& path) {
  double length = 0;
  for (size_t j = 0; j + 1 < path.waypoints.size(); ++j) {
    length += space.Distance(path.waypoints[j], path.waypoints[j + 1]);
  }
  return length;
}

class PlanTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { maze_ = new Fixture(LoadBuiltIn("maze")); }
  static void TearDownTestSuite() {
    delete maze_;
    maze_ = nullptr;
  }
  static Fixture* maze_;
};
Fixture* PlanTest::maze_ = nullptr;

TEST(PlannerTypeTest, NamesRoundTripAndUnknownNamesAreListed) {
  EXPECT_EQ(AllPlannerTypes().size(), 10u);
  for (PlannerType type : AllPlannerTypes()) {
    EXPECT_EQ(ParsePlannerType(PlannerTypeName(type), "planner"), type);
  }
  EXPECT_EQ(ParsePlannerType("rrt-connect", "planner"), PlannerType::kRRTConnect);
  EXPECT_EQ(ParsePlannerType("bit-star", "planner"), PlannerType::kBITStar);
  EXPECT_EQ(ParsePlannerType("informed-rrt-star", "planner"), PlannerType::kInformedRRTStar);
  EXPECT_TRUE(IsOptimizingPlanner(PlannerType::kBITStar));
  EXPECT_TRUE(IsOptimizingPlanner(PlannerType::kPRMStar));
  EXPECT_FALSE(IsOptimizingPlanner(PlannerType::kRRTConnect));
  try {
    ParsePlannerType("est", "--planner");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "--planner");
    EXPECT_NE(std::string(e.what()).find("unknown planner 'est'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("prm-cycles"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bitstar"), std::string::npos) << e.what();
  }
}

// The asymptotically optimal planners on the maze: each keeps improving until its time is up
// (it does not stop at its first solution) and returns its path between the exact endpoints,
// kept even if our check (stricter than the motion check OMPL planned with: it also rejects
// touching contact) fails it, and then reported uncertified at the edge CheckPaths rejects.
TEST_F(PlanTest, OptimizingPlannersSpendTheirTimeAndReportWhetherTheirPathIsCertified) {
  for (PlannerType type : {PlannerType::kRRTStar, PlannerType::kInformedRRTStar,
                           PlannerType::kBITStar, PlannerType::kAITStar, PlannerType::kPRMStar}) {
    SCOPED_TRACE(PlannerTypeName(type));
    PlanRequest request = MazeRequest(*maze_, type, 5);
    request.count = 1;
    request.time_s = 1.0;
    request.keep_uncertified = true;
    const PlanResult result = PlanPaths(*maze_->planner, request);
    ASSERT_EQ(result.paths.size(), 1u) << result.attempts[0].status;
    const PlanAttempt& attempt = result.attempts[0];
    EXPECT_TRUE(attempt.found);
    // The termination condition is the budget alone: the run lasts at least that long.
    EXPECT_GE(attempt.elapsed_ms, 0.9 * request.time_s * 1e3) << attempt.status;
    const InputPath& path = result.paths[0];
    EXPECT_EQ(path.name, std::string(PlannerTypeName(type)) + "-0");
    EXPECT_EQ(path.waypoints.front(), *maze_->scene->start);
    EXPECT_EQ(path.waypoints.back(), *maze_->scene->goal);
    const PathCheckResult check = CheckPaths(*maze_->planner, {.paths = {path}});
    EXPECT_EQ(check.paths[0].valid && check.paths[0].certified, attempt.certified);
    if (attempt.certified) {
      EXPECT_EQ(attempt.invalid_edge, -1);
      ExpectValid(*maze_->planner, path);
    } else {
      EXPECT_EQ(check.paths[0].invalid_edge, attempt.invalid_edge) << attempt.status;
    }
  }
}

TEST_F(PlanTest, EveryPlannerFindsValidPathsWithExactEndpoints) {
  for (PlannerType type : {PlannerType::kPRM, PlannerType::kPRMCycles, PlannerType::kPRMStar,
                           PlannerType::kRRT, PlannerType::kRRTConnect, PlannerType::kLazyPRM}) {
    SCOPED_TRACE(PlannerTypeName(type));
    PlanRequest request = MazeRequest(*maze_, type, 7);
    // The planners that use their whole budget need not run for long on a 2D maze.
    if (type == PlannerType::kPRMCycles || type == PlannerType::kPRMStar) request.time_s = 0.5;
    int callbacks = 0;
    request.on_path = [&](const PlanAttempt& attempt, const InputPath& path) {
      EXPECT_EQ(attempt.index, callbacks++);
      EXPECT_TRUE(attempt.certified);
      EXPECT_FALSE(path.waypoints.empty());
    };
    const PlanResult result = PlanPaths(*maze_->planner, request);
    ASSERT_EQ(result.attempts.size(), 2u);
    ASSERT_EQ(result.paths.size(), 2u) << result.attempts[0].status;
    EXPECT_EQ(callbacks, 2);
    for (const InputPath& path : result.paths) {
      EXPECT_EQ(path.waypoints.front(), *maze_->scene->start);
      EXPECT_EQ(path.waypoints.back(), *maze_->scene->goal);
      ExpectValid(*maze_->planner, path);
    }
    EXPECT_EQ(result.paths[1].name, std::string(PlannerTypeName(type)) + "-1");
    EXPECT_TRUE(result.attempts[1].found);
    EXPECT_NEAR(result.attempts[1].length, Length(maze_->scene->space, result.paths[1]), 1e-9);
  }
}

// Planners that stop at their first solution and sample single-threaded reproduce exactly.
TEST_F(PlanTest, SameSeedSamePathsForSingleThreadedPlanners) {
  for (PlannerType type : {PlannerType::kRRT, PlannerType::kRRTConnect, PlannerType::kLazyPRM}) {
    SCOPED_TRACE(PlannerTypeName(type));
    const PlanResult a = PlanPaths(*maze_->planner, MazeRequest(*maze_, type, 11));
    const PlanResult b = PlanPaths(*maze_->planner, MazeRequest(*maze_, type, 11));
    const PlanResult c = PlanPaths(*maze_->planner, MazeRequest(*maze_, type, 12));
    ASSERT_EQ(a.paths.size(), 2u);
    ASSERT_EQ(b.paths.size(), 2u);
    ASSERT_EQ(c.paths.size(), 2u);
    for (size_t i = 0; i < a.paths.size(); ++i) {
      EXPECT_EQ(a.paths[i].waypoints, b.paths[i].waypoints) << "path " << i;
    }
    // Paths within one request differ (each has its own seed), and another seed differs.
    EXPECT_NE(a.paths[0].waypoints, a.paths[1].waypoints);
    EXPECT_NE(a.paths[0].waypoints, c.paths[0].waypoints);
  }
}

// OMPL's PRM grows its roadmap for as long as its time-based termination allows, so how many
// samples it draws (and which path it returns) depends on the machine's load: same-seed
// reproduction is asserted for the tree planners above only. What holds for PRM on every
// machine: each run returns a valid path between the query's ends.
TEST_F(PlanTest, ForestPRMFindsValidPathsOnAnEasyScene) {
  const PlanRequest request = MazeRequest(*maze_, PlannerType::kPRM, 3);
  const PlanResult a = PlanPaths(*maze_->planner, request);
  ASSERT_EQ(a.paths.size(), 2u);
  for (const InputPath& path : a.paths) {
    ExpectValid(*maze_->planner, path);
    EXPECT_EQ(path.waypoints.front(), request.start);
    EXPECT_EQ(path.waypoints.back(), request.goal);
  }
}

TEST(PlanNoPathTest, NoPathInTimeIsReportedNotThrown) {
  // A point in a box split by a wall: start and goal are in different rooms.
  auto scene = std::make_shared<Scene>(Scene{
      .name = "two-rooms",
      .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)),
  });
  Obstacle wall{.name = "wall",
                .shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(0.5, 20, 1)}};
  wall.pose.translation() = Eigen::Vector3d(5, 5, 0);
  scene->obstacles.push_back(wall);
  scene->robot.push_back(
      RobotBody{.name = "point", .shape = Shape{.type = ShapeType::kSphere, .radius = 0.1}});
  auto world = std::make_shared<const CollisionWorld>(scene);
  const LocalPlanner planner(world);
  for (PlannerType type : {PlannerType::kPRM, PlannerType::kRRTConnect, PlannerType::kRRT}) {
    SCOPED_TRACE(PlannerTypeName(type));
    const PlanResult result = PlanPaths(planner, {.planner = type,
                                                  .start = Eigen::Vector2d(2, 5),
                                                  .goal = Eigen::Vector2d(8, 5),
                                                  .count = 2,
                                                  .time_s = 0.2});
    EXPECT_TRUE(result.paths.empty());
    ASSERT_EQ(result.attempts.size(), 2u);
    for (const PlanAttempt& a : result.attempts) {
      EXPECT_FALSE(a.found);
      EXPECT_NE(a.status.find("no path"), std::string::npos) << a.status;
    }
  }
}

TEST(PlanNoPathTest, EachFailedAttemptReachesOnFailureWithItsReasonAndSeed) {
  // The two rooms again: every attempt fails, whatever its seed.
  auto scene = std::make_shared<Scene>(Scene{
      .name = "two-rooms",
      .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)),
  });
  Obstacle wall{.name = "wall",
                .shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(0.5, 20, 1)}};
  wall.pose.translation() = Eigen::Vector3d(5, 5, 0);
  scene->obstacles.push_back(wall);
  scene->robot.push_back(
      RobotBody{.name = "point", .shape = Shape{.type = ShapeType::kSphere, .radius = 0.1}});
  auto world = std::make_shared<const CollisionWorld>(scene);
  const LocalPlanner planner(world);
  std::vector<PlanAttempt> failures;
  int paths = 0;
  const PlanResult result =
      PlanPaths(planner, {.planner = PlannerType::kRRTConnect,
                          .start = Eigen::Vector2d(2, 5),
                          .goal = Eigen::Vector2d(8, 5),
                          .count = 3,
                          .time_s = 0.05,
                          .seed = 42,
                          .on_path = [&](const PlanAttempt&, const InputPath&) { ++paths; },
                          .on_failure = [&](const PlanAttempt& a) { failures.push_back(a); }});
  EXPECT_EQ(paths, 0);
  ASSERT_EQ(failures.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    SCOPED_TRACE(i);
    const PlanAttempt& a = failures[i];
    EXPECT_EQ(a.index, i);  // in index order, one each
    EXPECT_FALSE(a.found);
    EXPECT_EQ(a.failure, PlanFailure::kNoSolution);
    EXPECT_EQ(a.seed, PlanAttemptSeed(42, i));
    EXPECT_EQ(a.invalid_edge, -1);
    EXPECT_NE(a.status.find("no path in 0.05 s (OMPL: "), std::string::npos) << a.status;
    EXPECT_EQ(a.status, result.attempts[i].status);
  }
  // Every attempt draws its own seed.
  EXPECT_NE(failures[0].seed, failures[1].seed);
}

TEST_F(PlanTest, AttemptsThatFindAPathDoNotReachOnFailure) {
  PlanRequest request = MazeRequest(*maze_, PlannerType::kRRTConnect, 3);
  int failures = 0;
  request.on_failure = [&](const PlanAttempt&) { ++failures; };
  const PlanResult result = PlanPaths(*maze_->planner, request);
  ASSERT_EQ(result.paths.size(), 2u);
  EXPECT_EQ(failures, 0);
  for (const PlanAttempt& a : result.attempts) {
    EXPECT_TRUE(a.found);
    EXPECT_EQ(a.failure, PlanFailure::kNone);
    EXPECT_EQ(a.seed, PlanAttemptSeed(3, a.index));
  }
}

TEST_F(PlanTest, BadRequestsNameTheField) {
  const auto field_of = [&](PlanRequest request) {
    try {
      PlanPaths(*maze_->planner, request);
    } catch (const InputError& e) {
      return e.field() + " | " + e.what();
    }
    return std::string("no error");
  };
  PlanRequest request = MazeRequest(*maze_, PlannerType::kRRT, 1);
  request.count = 0;
  EXPECT_EQ(field_of(request).substr(0, 8), "count | ");
  request = MazeRequest(*maze_, PlannerType::kRRT, 1);
  request.time_s = 0;
  EXPECT_EQ(field_of(request).substr(0, 9), "time_s | ");
  request = MazeRequest(*maze_, PlannerType::kRRT, 1);
  request.start = Eigen::Vector2d(0.1, 0.1);  // inside the outer wall
  EXPECT_NE(field_of(request).find("start | start: is in collision"), std::string::npos)
      << field_of(request);
  request = MazeRequest(*maze_, PlannerType::kRRT, 1);
  request.goal = Eigen::Vector3d(1, 1, 1);
  EXPECT_EQ(field_of(request).substr(0, 7), "goal | ");
}

TEST_F(PlanTest, CancelStopsPlanning) {
  PlanRequest request = MazeRequest(*maze_, PlannerType::kPRMStar, 1);
  request.time_s = 30;
  request.cancel.Cancel();
  try {
    PlanPaths(*maze_->planner, request);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled);
  }
}

TEST_F(PlanTest, ShortcutAndOmplHybridizationKeepPathsValidAndNoLonger) {
  PlanRequest request = MazeRequest(*maze_, PlannerType::kPRM, 5);
  request.count = 3;
  const PlanResult planned = PlanPaths(*maze_->planner, request);
  ASSERT_EQ(planned.paths.size(), 3u);
  const Space& space = maze_->scene->space;
  double shortest = 1e300;
  for (const InputPath& path : planned.paths) shortest = std::min(shortest, Length(space, path));

  // OMPL's shortcutting and its full simplification of one input: valid, the same ends, shorter,
  // and seeded (the same seed simplifies the same way).
  const InputPath& input = planned.paths[0];
  const std::vector<std::function<InputPath()>> simplifications = {
      [&] { return ShortcutPath(*maze_->planner, input, {.resolution = maze_->resolution}); },
      [&] { return SimplifyMaxPath(*maze_->planner, input, {.resolution = maze_->resolution}); }};
  for (const auto& simplify : simplifications) {
    const InputPath simplified = simplify();
    ExpectValid(*maze_->planner, simplified);
    EXPECT_EQ(simplified.waypoints.front(), input.waypoints.front());
    EXPECT_EQ(simplified.waypoints.back(), input.waypoints.back());
    EXPECT_LT(Length(space, simplified), Length(space, input));
    EXPECT_EQ(simplified.waypoints, simplify().waypoints);
  }

  const InputPath hybrid =
      OmplHybridize(*maze_->planner, planned.paths, {.resolution = maze_->resolution});
  ExpectValid(*maze_->planner, hybrid);
  EXPECT_EQ(hybrid.waypoints.front(), *maze_->scene->start);
  EXPECT_EQ(hybrid.waypoints.back(), *maze_->scene->goal);
  EXPECT_LE(Length(space, hybrid), shortest + 1e-9);

  // Both simplifications need an edge to work on.
  const InputPath one{.name = "one", .waypoints = {*maze_->scene->start}};
  for (const auto& simplify : std::vector<std::function<void()>>{
           [&] { ShortcutPath(*maze_->planner, one); },
           [&] { SimplifyMaxPath(*maze_->planner, one); },
           [&] { SimplifyMaxPath(*maze_->planner, InputPath{.name = "none"}); }}) {
    try {
      simplify();
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), "path");
    }
  }
}

// The built-in scenes load, their queries are valid, and the paper's PRM solves each. PRM stops at
// its first solution; the budget is generous so that a loaded machine does not fail the test
// (how fast PRM is belongs to the benchmarks and scenes/README.md, not here).
// A checker that answers as `inner` does, but holds its first CheckEdge (made inside OMPL's
// solve(): the endpoints are checked with IsValid) until Open() or a 30 s safety timeout.
class GatedChecker final : public MotionChecker {
 public:
  explicit GatedChecker(const MotionChecker& inner) : inner_(inner) {}
  const Space& space() const override { return inner_.space(); }
  EdgeReport CheckEdge(const EdgeCheckRequest& request) const override {
    std::unique_lock lock(mutex_);
    if (!entered_) {
      entered_ = true;
      changed_.notify_all();
      changed_.wait_for(lock, std::chrono::seconds(30), [this] { return open_; });
      held_ = false;
    }
    lock.unlock();
    return inner_.CheckEdge(request);
  }
  bool IsValid(const Config& q) const override { return inner_.IsValid(q); }
  double Clearance(const Config& q) const override { return inner_.Clearance(q); }
  int64_t total_collision_checks() const override { return inner_.total_collision_checks(); }
  int64_t total_distance_queries() const override { return inner_.total_distance_queries(); }

  bool WaitEntered() const {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, std::chrono::seconds(60), [this] { return entered_; });
  }
  // True while the first check is still held.
  bool Held() const {
    std::lock_guard lock(mutex_);
    return held_;
  }
  void Open() const {
    std::lock_guard lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }

 private:
  const MotionChecker& inner_;
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  mutable bool entered_ = false;
  mutable bool open_ = false;
  mutable bool held_ = true;
};

// While one run is inside OMPL's solve() (held there by its checker), another run plans and
// returns: the process-wide OMPL lock covers only the construction of each run's objects, not
// the search (a server's concurrent PlanPaths calls would otherwise queue up on it, each one
// parking a worker thread).
TEST_F(PlanTest, ConcurrentRunsSearchInParallel) {
  const GatedChecker gated(*maze_->planner);
  PlanRequest held = MazeRequest(*maze_, PlannerType::kRRTConnect, 21);
  held.count = 1;
  auto first = std::async(std::launch::async, [&] { return PlanPaths(gated, held); });
  ASSERT_TRUE(gated.WaitEntered());
  PlanRequest other = MazeRequest(*maze_, PlannerType::kRRTConnect, 22);
  other.count = 1;
  const PlanResult second = PlanPaths(*maze_->planner, other);
  const bool first_still_held = gated.Held();
  gated.Open();
  const PlanResult first_result = first.get();
  EXPECT_TRUE(first_still_held) << "the second run waited for the first one's search";
  EXPECT_EQ(second.paths.size(), 1u);
  EXPECT_EQ(first_result.paths.size(), 1u);
}

// A checker that answers as `inner` does, and cancels `token` when it is asked for a certificate
// (with OMPL's discrete check, the certificates of the planner's path after its search).
class CancelOnCertificate final : public MotionChecker {
 public:
  CancelOnCertificate(const MotionChecker& inner, CancelToken token)
      : inner_(inner), token_(std::move(token)) {}
  const Space& space() const override { return inner_.space(); }
  EdgeReport CheckEdge(const EdgeCheckRequest& request) const override {
    if (request.proof == EdgeProof::kCertificate) token_.Cancel();
    return inner_.CheckEdge(request);
  }
  bool IsValid(const Config& q) const override { return inner_.IsValid(q); }
  double Clearance(const Config& q) const override { return inner_.Clearance(q); }
  int64_t total_collision_checks() const override { return inner_.total_collision_checks(); }
  int64_t total_distance_queries() const override { return inner_.total_distance_queries(); }

 private:
  const MotionChecker& inner_;
  CancelToken token_;
};

// The certificates of a planner's path stop with the request's cancel token, as its search does
// (a Solve's planners end at its budget, not after certifying a long path on a large mesh).
TEST_F(PlanTest, CertifyingAPathStopsWhenTheRunIsCancelled) {
  PlanRequest request = MazeRequest(*maze_, PlannerType::kRRTConnect, 51);
  request.count = 1;
  request.motion_check = OmplMotionCheck::kDiscrete;
  const CancelOnCertificate checker(*maze_->planner, request.cancel);
  try {
    const PlanResult result = PlanPaths(checker, request);
    FAIL() << "the run went on past its cancel: " << result.paths.size() << " paths";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled) << e.what();
  }
}

// Seeds stay reproducible when runs overlap: each run's samplers are drawn under the lock.
TEST_F(PlanTest, SameSeedSamePathsWhenRunsOverlap) {
  const PlanRequest a = MazeRequest(*maze_, PlannerType::kRRTConnect, 31);
  const PlanRequest b = MazeRequest(*maze_, PlannerType::kRRT, 32);
  const PlanResult alone_a = PlanPaths(*maze_->planner, a);
  const PlanResult alone_b = PlanPaths(*maze_->planner, b);
  auto together_a = std::async(std::launch::async, [&] { return PlanPaths(*maze_->planner, a); });
  auto together_b = std::async(std::launch::async, [&] { return PlanPaths(*maze_->planner, b); });
  const PlanResult ra = together_a.get();
  const PlanResult rb = together_b.get();
  ASSERT_EQ(ra.paths.size(), alone_a.paths.size());
  ASSERT_EQ(rb.paths.size(), alone_b.paths.size());
  for (size_t i = 0; i < ra.paths.size(); ++i) {
    EXPECT_EQ(ra.paths[i].waypoints, alone_a.paths[i].waypoints) << i;
  }
  for (size_t i = 0; i < rb.paths.size(); ++i) {
    EXPECT_EQ(rb.paths[i].waypoints, alone_b.paths[i].waypoints) << i;
  }
}

// `simplify` shortcuts each path (ShortcutPath takes the OMPL lock itself: the planning loop
// must not hold it then).
TEST_F(PlanTest, SimplifiedPathsAreReturnedValidAndNoLonger) {
  PlanRequest request = MazeRequest(*maze_, PlannerType::kRRTConnect, 41);
  request.count = 1;
  PlanRequest simplified = request;
  simplified.simplify = true;
  auto run = std::async(std::launch::async, [&] { return PlanPaths(*maze_->planner, simplified); });
  if (run.wait_for(std::chrono::seconds(120)) != std::future_status::ready) {
    ADD_FAILURE() << "PlanPaths with simplify did not return (deadlock)";
    std::_Exit(1);
  }
  const PlanResult plain = PlanPaths(*maze_->planner, request);
  const PlanResult shortcut = run.get();
  ASSERT_EQ(plain.paths.size(), 1u);
  ASSERT_EQ(shortcut.paths.size(), 1u);
  ExpectValid(*maze_->planner, shortcut.paths[0]);
  EXPECT_LE(Length(maze_->scene->space, shortcut.paths[0]),
            Length(maze_->scene->space, plain.paths[0]) + 1e-9);
}

TEST(BuiltInScenesTest, PRMSolvesEveryScene) {
  for (const std::string name : {"maze", "grid", "wrench", "double_wrench", "circles"}) {
    SCOPED_TRACE(name);
    const Fixture f = LoadBuiltIn(name);
    ASSERT_TRUE(f.scene->start && f.scene->goal);
    const PlanResult result = PlanPaths(*f.planner, {.planner = PlannerType::kPRM,
                                                     .start = *f.scene->start,
                                                     .goal = *f.scene->goal,
                                                     .count = 1,
                                                     .time_s = 120,
                                                     .seed = 1,
                                                     .resolution = f.resolution});
    ASSERT_EQ(result.paths.size(), 1u) << result.attempts[0].status;
    ExpectValid(*f.planner, result.paths[0]);
    std::printf("%s: PRM found a path in %.1f ms\n", name.c_str(), result.attempts[0].elapsed_ms);
  }
}

// A motion to a state within a hair of an obstacle (clearance 4.6e-5; an edge of a path PRM
// planned on double_wrench): free at every sample of its profile, yet no certificate covers it,
// so a merge cannot take it. OMPL planning on our certified check refused it not (it took the
// profile's "valid"), so PlanPaths returned a path the merge of the same paths then failed on.
TEST(PlanCertifiedTest, AMotionFreeAtItsSamplesButNotCertifiedIsRefusedWhilePlanning) {
  const Fixture f = LoadBuiltIn("double_wrench");
  const Space& space = f.scene->space;
  Config a(14), b(14);
  a << 0.14903882127190848, 3.214079650041639, 0.6468998484563832, 0.661923877867914,
      -0.20223006326142834, -0.25629448848604414, 0.6747391470733404, -2.618356669982539,
      0.9020865079822455, -1.4454333804751818, -0.23661697012118624, -0.5888890931526779,
      -0.28992334734801833, 0.7163564043679702;
  b << 0.18034094074746623, 3.2068446441966856, 0.6346256758945156, 0.661136406266895,
      -0.19681778449395684, -0.25961243940547496, 0.6758422843543636, -2.6077252141481964,
      0.8571587667825886, -1.4085136364044177, -0.24276065777733505, -0.5964240610495646,
      -0.28529924216408187, 0.7098943194992208;
  const EdgeReport profiled =
      f.planner->CheckEdge({.from = &a, .to = &b, .proof = EdgeProof::kProfile});
  ASSERT_EQ(profiled.state, EdgeState::kValid);
  ASSERT_FALSE(profiled.certified);
  const PathCheckResult check =
      CheckPaths(*f.planner, {.paths = {{.name = "e", .waypoints = {a, b}}}});
  ASSERT_TRUE(check.paths[0].valid);
  EXPECT_FALSE(check.paths[0].certified);

  const ompl::base::SpaceInformationPtr si =
      plan_internal::MakeSpaceInformation(*f.planner, f.resolution);
  ompl::base::ScopedState<> from(si), to(si);
  plan_internal::ToOmpl(space, a, from.get());
  plan_internal::ToOmpl(space, b, to.get());
  EXPECT_FALSE(si->checkMotion(from.get(), to.get()));
  std::pair<ompl::base::State*, double> last_valid{nullptr, -1};
  EXPECT_FALSE(si->checkMotion(from.get(), to.get(), last_valid));
  EXPECT_LT(last_valid.second, 1.0);
}

// Counts the motions asked of the checker, answering as `inner` does.
class CountingChecker final : public MotionChecker {
 public:
  explicit CountingChecker(const MotionChecker& inner) : inner_(inner) {}
  const Space& space() const override { return inner_.space(); }
  EdgeReport CheckEdge(const EdgeCheckRequest& request) const override {
    ++edges_;
    return inner_.CheckEdge(request);
  }
  bool IsValid(const Config& q) const override { return inner_.IsValid(q); }
  double Clearance(const Config& q) const override { return inner_.Clearance(q); }
  int64_t total_collision_checks() const override { return inner_.total_collision_checks(); }
  int64_t total_distance_queries() const override { return inner_.total_distance_queries(); }
  int64_t edges() const { return edges_; }

 private:
  const MotionChecker& inner_;
  mutable std::atomic<int64_t> edges_{0};
};

// A planner polls its stop only between its steps (PRM: between milestones, each up to ten
// motions): once the attempt is stopped, the certified motion validator refuses every motion
// without asking the checker, so that a stop is not held up by checks whose answer is no longer
// of use.
TEST(PlanCertifiedTest, OnceStoppedTheMotionValidatorRefusesMotionsUnchecked) {
  const Fixture f = LoadBuiltIn("maze");
  const Space& space = f.scene->space;
  const Config a = *f.scene->start;
  const Config b = space.Interpolate(a, *f.scene->goal, 1e-3);
  ASSERT_TRUE(
      f.planner->CheckEdge({.from = &a, .to = &b, .proof = EdgeProof::kCertificate}).certified);
  CountingChecker counting(*f.planner);
  std::atomic<bool> stop{false};
  const ompl::base::SpaceInformationPtr si = plan_internal::MakeSpaceInformation(
      counting, f.resolution, OmplMotionCheck::kCertified, [&stop] { return stop.load(); });
  ompl::base::ScopedState<> from(si), to(si);
  plan_internal::ToOmpl(space, a, from.get());
  plan_internal::ToOmpl(space, b, to.get());
  EXPECT_TRUE(si->checkMotion(from.get(), to.get()));
  const int64_t asked = counting.edges();
  EXPECT_GE(asked, 1);
  stop = true;
  EXPECT_FALSE(si->checkMotion(from.get(), to.get()));
  std::pair<ompl::base::State*, double> last_valid{nullptr, -1};
  EXPECT_FALSE(si->checkMotion(from.get(), to.get(), last_valid));
  EXPECT_EQ(last_valid.second, 0.0);
  EXPECT_EQ(counting.edges(), asked);
}

// OMPL as shipped (OmplMotionCheck::kDiscrete) checks the states at the resolution's steps only:
// simplifyMax then takes a shortcut straight through a wall thinner than a step, which CheckPaths
// finds in collision, and never asks our checker for a motion. The certified check keeps the
// detour over the wall.
TEST(OmplAsShippedTest, DiscreteChecksCrossAWallThinnerThanAStep) {
  // A point robot in [0, 10]^2 (extent 10 sqrt 2: a step of 0.707 at resolution 0.05) and a wall
  // 0.02 thick at x = 5 from y = 0 to 9.
  auto scene = std::make_shared<Scene>(Scene{
      .name = "thin wall",
      .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)),
  });
  Obstacle wall{.name = "wall",
                .shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(0.02, 9, 1)}};
  wall.pose.translation() = Eigen::Vector3d(5, 4.5, 0);
  scene->obstacles.push_back(wall);
  scene->robot.push_back(RobotBody{.shape = Shape{.type = ShapeType::kSphere, .radius = 0}});
  const double resolution = 0.05;
  const LocalPlanner planner(std::make_shared<CollisionWorld>(scene), {.resolution = resolution});
  // Over the wall's end; the straight motion from (1, 1) to (9.5, 1) has its samples at
  // x = 1 + 8.5 i / 13, none of them inside the wall.
  const InputPath detour{
      .name = "detour",
      .waypoints = {Eigen::Vector2d(1, 1), Eigen::Vector2d(5, 9.5), Eigen::Vector2d(9.5, 1)}};
  ASSERT_TRUE(CheckPaths(planner, {.paths = {detour}}).paths[0].valid);

  const CountingChecker counting(planner);
  const InputPath shipped = SimplifyMaxPath(
      counting, detour, {.resolution = resolution, .motion_check = OmplMotionCheck::kDiscrete});
  EXPECT_EQ(counting.edges(), 0);
  const InputPath certified = SimplifyMaxPath(planner, detour, {.resolution = resolution});

  const PathCheckResult check = CheckPaths(planner, {.paths = {shipped, certified}});
  EXPECT_FALSE(check.paths[0].valid);
  EXPECT_EQ(check.paths[0].invalid_cause, InvalidCause::kCollision);
  EXPECT_TRUE(check.paths[1].valid);
  EXPECT_TRUE(check.paths[1].certified);
  EXPECT_LT(Length(scene->space, shipped), Length(scene->space, certified));
}

// A planner that checks its motions at samples only (sampled_motions) crosses the thin wall
// between two samples. Its path fails our check: a failed attempt by default, and with
// keep_uncertified the same path is returned, reported uncertified at the edge that crosses.
TEST(OmplAsShippedTest, UncertifiedPathsAreKeptOnlyWhenAskedAndReportedAsSuch) {
  auto scene = std::make_shared<Scene>(Scene{
      .name = "thin wall",
      .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)),
  });
  Obstacle wall{.name = "wall",
                .shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(0.02, 9, 1)}};
  wall.pose.translation() = Eigen::Vector3d(5, 4.5, 0);
  scene->obstacles.push_back(wall);
  scene->robot.push_back(RobotBody{.shape = Shape{.type = ShapeType::kSphere, .radius = 0}});
  const double resolution = 0.05;
  const LocalPlanner planner(std::make_shared<CollisionWorld>(scene), {.resolution = resolution});
  PlanRequest request{.planner = PlannerType::kRRTConnect,
                      .start = Eigen::Vector2d(1, 1),
                      .goal = Eigen::Vector2d(9.5, 1),
                      .count = 1,
                      .time_s = 2,
                      .seed = 3,
                      .resolution = resolution,
                      .motion_check = OmplMotionCheck::kDiscrete};
  const PlanResult rejected = PlanPaths(planner, request);
  ASSERT_EQ(rejected.attempts.size(), 1u);
  EXPECT_TRUE(rejected.paths.empty());
  EXPECT_EQ(rejected.attempts[0].failure, PlanFailure::kInvalidEdge);
  EXPECT_FALSE(rejected.attempts[0].certified);

  request.keep_uncertified = true;
  std::vector<PlanAttempt> streamed;
  request.on_path = [&](const PlanAttempt& a, const InputPath&) { streamed.push_back(a); };
  const PlanResult kept = PlanPaths(planner, request);
  ASSERT_EQ(kept.paths.size(), 1u);
  const PlanAttempt& a = kept.attempts[0];
  EXPECT_TRUE(a.found);
  EXPECT_FALSE(a.certified);
  EXPECT_EQ(a.failure, PlanFailure::kNone);
  EXPECT_EQ(a.invalid_edge, rejected.attempts[0].invalid_edge);
  ASSERT_EQ(streamed.size(), 1u);
  EXPECT_FALSE(streamed[0].certified);
  EXPECT_EQ(streamed[0].invalid_edge, a.invalid_edge);
  const PathCheckResult check = CheckPaths(planner, {.paths = kept.paths});
  EXPECT_FALSE(check.paths[0].valid);
  EXPECT_EQ(check.paths[0].invalid_edge, a.invalid_edge);
  // The same planner checking motions as a merge does keeps to the free side of the wall.
  request.motion_check = OmplMotionCheck::kCertified;
  const PlanResult certified = PlanPaths(planner, request);
  ASSERT_EQ(certified.paths.size(), 1u) << certified.attempts[0].status;
  EXPECT_TRUE(certified.attempts[0].certified);
}

}  // namespace
}  // namespace hgraph
